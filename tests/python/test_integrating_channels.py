"""Integrating channels (a level loop: a lag before an integrator, the OP at its balance somewhere
away from the record's mean): detect monitors them with the recommended presets, diagnose names a
gain change of one and its size, and a record without a change gives neither an alarm nor a
finding (before 2026-11-30 detect refused such a model and diagnose found an output drift in
every record of it). Draws of the tuning family pi_level."""
import numpy as np
import pytest
from scipy import signal

import mpmpp
from mpmpp import families
from mpmpp._core import TransferFunction as TF
from mpmpp.compare import compare
from mpmpp.detect import detect
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose
from mpmpp.evaluate import nominal_model
from mpmpp.integrating import integrating_channels, integrates
from mpmpp.step_response import step_response_error
from mpmpp.update import update

LEVEL = families.family("pi_level")


def level_loop(seed: int, effect: str):
    spec, expect = LEVEL.draw(seed, effect=effect)
    return nominal_model(spec), mpmpp.simulate(spec), expect


def test_a_pole_at_one_is_an_integrator_and_nothing_else_is():
    assert integrates(TF([0.05], [1.0, -1.6, 0.6], 2))
    assert not integrates(TF([0.05], [1.0, -0.6], 2))
    assert not integrates(TF([0.05], [1.0, -1.0 + 1e-6], 2))   # a pole near 1 is a slow lag
    model, _, _ = level_loop(0, "none")
    assert integrating_channels(model) == [("y1", "u1")]


def test_step_response_error_of_an_integrator_compares_rate_responses():
    """Against a NumPy reference: the RMS difference of the impulse responses (the rate
    responses) over the lag's settling horizon, relative to the rate gain."""
    ref = TF([0.05 * 0.4], [1.0, -1.6, 0.6], 2)
    changed = TF([0.08 * 0.4], [1.0, -1.6, 0.6], 2)
    n = 2 + int(5 * -1 / np.log(0.6) + 10)
    impulse = np.r_[1.0, np.zeros(n - 1)]

    def rate(g):   # impulse response of G = step response of (1 - q^-1) G
        return signal.lfilter(np.r_[np.zeros(g.delay), g.num], g.den, impulse)

    expected = np.sqrt(np.mean((rate(ref) - rate(changed)) ** 2)) / 0.05
    assert step_response_error(changed, ref) == pytest.approx(expected, rel=1e-9)
    assert step_response_error(ref, ref) == 0.0
    # a channel that stopped integrating differs by the whole rate response
    assert step_response_error(None, ref) == pytest.approx(np.sqrt(np.mean(rate(ref) ** 2)) / 0.05, rel=1e-9)


def test_detect_alarms_on_a_gain_change_of_a_level_and_not_without_one():
    model, data, expect = level_loop(6, "gain")
    result = detect(model, data)
    starts = [a["start_s"] for a in result.alarms if a["kind"] == "process"]
    assert starts and min(starts) >= expect["onset_s"]
    model, data, _ = level_loop(0, "none")
    result = detect(model, data)
    assert not [a for a in result.alarms if a["kind"] == "process"]


def test_detect_paper_presets_say_what_an_integrator_needs():
    model, data, _ = level_loop(0, "none")
    with pytest.raises(ValueError, match="integrator the FIR features cannot hold"):
        detect(model, data, config="paper_siso")


def test_diagnose_names_the_gain_change_of_a_level_and_its_size():
    model, data, expect = level_loop(6, "gain")
    result = diagnose(model, data)
    top = next(f for f in result.findings if f.effect in PROCESS_EFFECTS)
    assert top.effect == "gain" and (top.output, top.input) == ("y1", "u1")
    assert top.estimate["gain_ratio"] == pytest.approx(expect["size"], abs=0.06)
    assert abs(top.onset_s - expect["onset_s"]) < 3600
    assert any("integrates (a pole at z = 1)" in n for n in result.notes)
    # the update keeps the integrator and scales the channel
    up = update(model, data, top.id)
    g0, g1 = model.process("y1", "u1"), up.model.process("y1", "u1")
    assert integrates(g1)
    assert g1.num[0] / g0.num[0] == pytest.approx(top.estimate["gain_ratio"], rel=0.05)


@pytest.mark.parametrize("seed", [0, 1])
def test_diagnose_finds_nothing_on_a_level_without_a_change(seed):
    """No process finding and no output drift: the integrator's ramp from an OP off its
    balance is no drift of the output."""
    model, data, _ = level_loop(seed, "none")
    assert diagnose(model, data).findings == []


def test_compare_takes_the_integrators_ramp_out_and_says_so():
    """An exact model of a level loop whose disturbance alone changed: no failing period, and a
    simulation fit far above the -1 % the integrator's ramp left before (pi_level seed 0)."""
    model, data, _ = level_loop(0, "noise_change")
    result = compare(model, data)
    out = result.outputs[0]
    assert out.failing == [] and out.fit_simulation > 30.0
    assert result.integrating and "y1 <- u1 integrates" in result.integrating[0]
