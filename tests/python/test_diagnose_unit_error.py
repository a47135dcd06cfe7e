"""A hand-written model whose channel is written in other units (kg/h for t/h: 1000x): the
gain finding from the record's start names the ratio legibly and points at the units, whichever
way the model is off."""
import pytest

import mpmpp
from mpmpp.diagnose import diagnose

import closed_loop_case as loop


def scaled_model(factor: float) -> mpmpp.Model:
    num, den, delay = loop.G
    return mpmpp.Model("units", loop.TS, ["u"], ["y"],
                       {"y": {"u": mpmpp.TransferFunction([num[0] * factor], den, delay)}},
                       {"y": mpmpp.TransferFunction(*loop.H)})


@pytest.mark.parametrize("factor, shown", [(1e-3, "x the model's throughout the record"),
                                           (1e3, "x the model's throughout the record")])
def test_a_model_in_other_units_is_read_as_such(factor, shown):
    res = diagnose(scaled_model(factor), loop.simulate(n=8000, seed=2))
    top = res.findings[0]
    assert top.effect == "gain" and top.onset_s == res.start_s
    ratio = top.estimate["gain_ratio"]
    assert 0.3 / factor < ratio < 3.0 / factor
    assert f"about {ratio:.3g}{shown}" in top.explanation
    assert "check the channel's units" in top.explanation


def test_a_model_nearly_right_gets_no_word_on_units():
    res = diagnose(scaled_model(0.5), loop.simulate(n=8000, seed=2))
    top = res.findings[0]
    assert top.effect == "gain" and 1.4 < top.estimate["gain_ratio"] < 2.8
    assert "units" not in top.explanation and f"about {top.estimate['gain_ratio']:.2f}x" in top.explanation
