"""A fast subset of the hidden-effect suite (studies/diagnose_eval.py): MPC closed-loop data from
mpmpp.simulate with an effect the model does not know."""

import pytest

import mpmpp
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose

import diagnose_eval as suite


def _run(effect, seed):
    sc, expect = suite.case(effect, seed)
    return diagnose(suite.model_of(sc), mpmpp.simulate(sc, seed=seed)), expect


def test_no_change_control_gives_no_finding():
    res, _ = _run("none", 0)
    assert res.findings == []


def test_noise_level_change_is_not_a_process_change():
    res, expect = _run("noise_level", 1)
    assert not [f for f in res.findings if f.effect in PROCESS_EFFECTS]
    assert suite.matches(res.findings[0], expect)


@pytest.mark.parametrize("effect,seed", [("delay", 0), ("output_drift", 1)])
def test_hidden_effect_is_the_top_finding(effect, seed):
    res, expect = _run(effect, seed)
    assert res.findings and suite.matches(res.findings[0], expect)
    assert res.findings[0].error_after < res.findings[0].error_before
