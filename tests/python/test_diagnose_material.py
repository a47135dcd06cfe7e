"""Practical significance of a channel change (diagnose/process.py, ``_material``): a change is
reported when it removes min_effect of the one-step error variance OR moves the channel's step
response by MATERIAL_STEP_CHANGE. With little excitation under a large disturbance a 1.6x gain
explains well under 1 % of the one-step error and must still be found."""
import importlib

import numpy as np
import pytest

from mpmpp import families as fam
from mpmpp._core import TransferFunction
from mpmpp.diagnose import diagnose
from mpmpp.diagnosis_study import nominal_model, simulate
from mpmpp.step_response import step_response_error

process = importlib.import_module("mpmpp.diagnose.process")


class _Out:
    """The one attribute ``_material`` reads of an OutputResidual: the held-out weights."""

    def __init__(self, n):
        self.weight = np.ones(n)


def _fit(effect, shape, nominal, theta, heldout, onset=0):
    s = process.Shape(effect, "u1", "input", shape, nominal, 1.0, 1)
    return process.Fit(s, onset, 0.0, heldout, theta, 0.01, [], 1.0)


def test_material_by_share_or_by_step_response():
    g = TransferFunction([0.2], [1.0, -0.8], 3)
    out = _Out(1000)
    # either test suffices: a large share, or a large step-response change
    assert process._material(out, _fit("gain", g, g, 1.02, heldout=20.0), 0.01)
    assert process._material(out, _fit("gain", g, g, 1.6, heldout=1.0), 0.01)
    assert not process._material(out, _fit("gain", g, g, 1.05, heldout=1.0), 0.01)
    # the threshold is the step-response error of theta * shape against the nominal channel
    for theta in (1.2, 1.3, 0.75):
        changed = TransferFunction([0.2 * theta], [1.0, -0.8], 3)
        want = step_response_error(changed, g) >= process.MATERIAL_STEP_CHANGE
        assert process._material(out, _fit("gain", g, g, theta, heldout=1.0), 0.01) == want
    # the share is of the error variance after the onset
    assert not process._material(out, _fit("gain", g, g, 1.02, heldout=6.0), 0.01)
    assert process._material(out, _fit("gain", g, g, 1.02, heldout=6.0, onset=500), 0.01)
    # a new channel has no nominal to compare with: only the share decides
    assert not process._material(out, _fit("missing_coupling", g, None, 5.0, heldout=1.0), 0.01)


@pytest.mark.parametrize("name,seed", [("mpc_siso_move_limits", 8)])
def test_a_gain_change_below_the_share_floor_is_reported(name, seed):
    spec, expect = fam.family(name).draw(seed, None, "gain")
    res = diagnose(nominal_model(spec), simulate(spec))
    top = next(f for f in res.findings if f.effect in ("gain", "time_constant", "delay"))
    assert top.effect == "gain" and top.input == expect["channels"][0][1]
    assert top.estimate["gain_ratio"] == pytest.approx(expect["size"], rel=0.2)
    assert abs(top.onset_s - expect["onset_s"]) < 3600.0
    # the one-step error barely moves (the disturbance dominates it) ...
    assert top.error_after > 0.98 * top.error_before
    # ... while the process part of the error falls
    assert top.process_error_after < 0.7 * top.process_error_before
