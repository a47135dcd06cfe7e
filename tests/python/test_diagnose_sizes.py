"""The SIZE of each diagnosed effect against the truth, with effects placed between the points
of the search grids (diagnose/shapes.py): gain ratio (continuous theta), time constant (grid
TIME_CONSTANT_FACTORS, refined between its points), dead time (integer grid, an uneven shift), coupling gain (continuous
theta on a grid of poles, the true pole between two of them), and the example case's coupling.

Data: the hidden-effect suite's MPC closed loop (studies/diagnose_eval.py, 2x2 MD plant, 16 h at
5 s, effect at 6 h), the channel alternating with the seed. Tolerances sit near what the method
achieves; measured over seeds 0-7 with the label right (docs/diagnose.md, "Effect sizes"):
gain ratio x1.7 within 4 %, x0.55 within 13 %; time constant (refined between the grid points)
x2.5 within 15 % on seeds 0-3 (2.34-3.28 on 0-7), x0.4 within 7 %, the gain kept within 0.94-1.27;
dead time +7 samples exact;
coupling gain 0.35 with pole 0.87 within 23 % (the pole snaps to 0.8 or 0.9 and the gain
absorbs part of the difference).
"""
import math

import pytest

import mpmpp
from mpmpp import families
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose
from mpmpp.diagnose.shapes import COUPLING_POLES, TIME_CONSTANT_FACTORS
from mpmpp.diagnosis_study import true_change, update_quality
from mpmpp.evaluate import nominal_model

import closed_loop_case as loop
import diagnose_eval as suite
from example_cases import MISSING_COUPLING, load_case

SEEDS = (0, 1, 2, 3)


def _between(grid, value):
    """The two grid points around ``value`` (which must not be one of them)."""
    assert value not in grid
    below = max(g for g in grid if g < value)
    above = min(g for g in grid if g > value)
    return below, above


def _top_process(sc, seed, effect, output, column):
    res = diagnose(suite.model_of(sc), mpmpp.simulate(sc, seed=seed))
    process = [f for f in res.findings if f.effect in PROCESS_EFFECTS]
    assert process, f"seed {seed}: no process finding"
    top = process[0]
    assert (top.effect, top.output, top.input) == (effect, output, column)
    return top


def _case(effect, seed, **event):
    sc, expect = suite.case(effect, seed)
    if event:
        sc["events"][0].update(event)
    return sc, expect


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("factor,tolerance", [(1.7, 0.06), (0.55, 0.15)])
def test_gain_ratio(seed, factor, tolerance):
    sc, expect = _case("gain", seed, factor=factor)
    top = _top_process(sc, seed, "gain", expect["output"], expect["input"])
    assert top.estimate["gain_ratio"] == pytest.approx(factor, rel=tolerance)


@pytest.mark.parametrize("seed", (0, 1))
@pytest.mark.parametrize("gain,reference,tolerance", [(0.5, -1.0, 0.06), (0.5, 1.0, 0.06), (2.0, -1.0, 0.08)])
def test_gain_ratio_about_another_operating_point(seed, gain, reference, tolerance):
    """A plant whose gain changes about an input value other than the record's mean also steps
    the output's level at the onset (closed_loop_case ``gain_reference``, one input unit either
    side of the loop's operating point). The gain is fitted with that step (shapes.Shape
    level_step) and its errors taken with it fitted out. Without (seeds 0-2): ratios 0.37-0.45
    for the x0.5 and 1.76-1.81 for the x2 at reference -1, an output drift reported beside the
    gain, and one x0.5 read as a sticking valve."""
    data = loop.simulate(n=8000, seed=seed, onset=4000, gain=gain, gain_reference=reference)
    res = diagnose(loop.model(), data)
    process = [f for f in res.findings if f.effect in PROCESS_EFFECTS]
    assert [f.effect for f in process] == ["gain"]
    assert process[0].estimate["gain_ratio"] == pytest.approx(gain, rel=tolerance)
    assert abs(process[0].onset_s / loop.TS - 4000) <= 60
    assert not any(f.effect == "output_drift" for f in res.findings)


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("factor,tolerance", [(2.5, 0.2), (0.4, 0.1)])
def test_time_constant_between_grid_points(seed, factor, tolerance):
    _between(TIME_CONSTANT_FACTORS, factor)
    sc, expect = _case("time_constant", seed, factor=factor)
    top = _top_process(sc, seed, "time_constant", expect["output"], expect["input"])
    # refined between the grid points, not snapped to one of them
    assert top.estimate["time_constant_ratio"] not in TIME_CONSTANT_FACTORS
    assert top.estimate["time_constant_ratio"] == pytest.approx(factor, rel=tolerance)
    # the time constant changed, the gain did not: the fitted channel scale stays near 1
    assert 0.8 <= top.estimate["gain_ratio"] <= 1.25
    g = suite.BASE["process"][expect["output"]][expect["input"]]
    tau_model = -suite.BASE["sample_time_s"] / math.log(-g["den"][1])
    assert top.estimate["time_constant_s"] == pytest.approx(tau_model * top.estimate["time_constant_ratio"], rel=1e-6)


@pytest.mark.parametrize("seed", SEEDS)
def test_dead_time(seed):
    sc, expect = suite.case("delay", seed)
    model_delay = sc["process"][expect["output"]][expect["input"]]["delay"]
    sc["events"][0]["delay"] = model_delay + 7
    top = _top_process(sc, seed, "delay", expect["output"], expect["input"])
    assert top.estimate["model_delay_samples"] == model_delay
    assert abs(top.estimate["delay_samples"] - (model_delay + 7)) <= 1
    assert top.estimate["delay_s"] == top.estimate["delay_samples"] * suite.BASE["sample_time_s"]
    # the dead time as the FOPTD form and `check` state it: one sample less than the first lag
    ts = suite.BASE["sample_time_s"]
    assert top.estimate["model_dead_time_s"] == pytest.approx((model_delay - 1) * ts)
    assert top.estimate["dead_time_s"] == pytest.approx((top.estimate["delay_samples"] - 1) * ts)
    lag = top.estimate["delay_samples"]
    assert f"instead of {(model_delay - 1) * ts:.3g} s (delay {lag} samples" in top.explanation


@pytest.mark.parametrize("seed", SEEDS)
def test_coupling_gain_with_an_off_grid_pole(seed):
    pole, gain, delay = 0.87, 0.35, 10
    _between(COUPLING_POLES, pole)
    sc, expect = suite.case("missing_coupling", seed)
    sc["truth"]["process"]["basis_weight"]["steam_pressure"] = suite._tf([gain * (1 - pole)], [1.0, -pole], delay)
    top = _top_process(sc, seed, "missing_coupling", expect["output"], expect["input"])
    assert top.estimate["gain"] == pytest.approx(gain, rel=0.25)
    assert abs(top.estimate["delay_samples"] - delay) <= 1
    lo, hi = top.estimate["ci95"]
    assert lo < top.estimate["gain"] < hi


def test_example_coupling_gain():
    """examples/mimo_missing_coupling: the gain answer.json names, within 5 % (measured 0.353 for 0.35)."""
    model, data, hidden = load_case(MISSING_COUPLING)
    res = diagnose(model, data)
    top = [f for f in res.findings if f.effect in PROCESS_EFFECTS][0]
    assert (top.effect, top.output, top.input) == (hidden["effect"], hidden["output"], hidden["input"])
    assert top.estimate["gain"] == pytest.approx(hidden["gain"], rel=0.05)
    lo, hi = top.estimate["ci95"]
    assert lo <= hidden["gain"] <= hi


@pytest.mark.parametrize("name,seed,factor", [("mpc_siso_clip", 1, 0.5), ("mpc_siso_move_limits", 19, 2.0)])
def test_a_time_constant_is_not_read_as_a_gain(name, seed, factor):
    """MPC loops in routine operation, whose input moves fast against the channel's time
    constant: there a shorter time constant looks like a larger gain (and a longer one like a
    smaller gain). Until 2026-11-30 a new time constant needed one parameter more than a gain
    (its scale theta was fitted) and both draws were named as gains (1.66x and 0.69x), each
    update moving the step response further from the truth (true error 0.12 -> 0.50 and 0.27).
    With the gain held, the time constant competes on the likelihood at the gain's parameter
    count (process._fits_of_shape). Draws of tuning families."""
    spec, expect = families.family(name).draw(seed, effect="time_constant")
    assert expect["size"] == factor
    model, data = nominal_model(spec), mpmpp.simulate(spec)
    top = [f for f in diagnose(model, data).findings if f.effect in PROCESS_EFFECTS][0]
    assert (top.effect, [top.output, top.input]) == ("time_constant", expect["channels"][0])
    assert top.estimate["time_constant_ratio"] == pytest.approx(factor, rel=0.1)
    assert top.estimate["gain_ratio"] == 1.0
    quality = update_quality(model, data, top, true_change(spec, expect))
    assert quality["true_after"] < 0.25 * quality["true_before"]
