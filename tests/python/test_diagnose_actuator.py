"""Actuator nonlinearity that sets in during the record (diagnose/actuator.py): the candidates
are scored with the AR noise correction refitted together with each (diagnose/refitted_noise.py,
a C++ kernel checked against a plain NumPy least-squares fit), and the right kind is named on seeded
closed-loop records while the same records with a linear valve get no such finding."""
import copy

import numpy as np
import pytest

from mpmpp import families
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose
from mpmpp.diagnose.process import DEAD_CHANNEL
from mpmpp.diagnose.refitted_noise import RefittedNoise
from mpmpp.evaluate import nominal_model
from mpmpp.simulate import simulate
from refitted_noise_reference import lag_vectors


def numpy_refitted(e, psi, onset, train, test, order):
    """AR(order) of x = e - 1[t >= onset] psi (on the lag vectors, as the module defines it)
    fitted by least squares on the rows ``train``; squared-error sums on ``train`` and ``test``."""
    z = lag_vectors(e, order) - (np.arange(len(e)) >= onset)[:, None] * lag_vectors(psi, order)
    a = np.linalg.lstsq(z[train, 1:], z[train, 0], rcond=None)[0]
    resid = z[:, 0] - z[:, 1:] @ a
    return float(np.sum(resid[train] ** 2)), float(np.sum(resid[test] ** 2))


@pytest.mark.parametrize("order", [5, 3])   # the kernel's fixed-size path (5) and its general one
def test_refitted_statistics_match_a_plain_least_squares_fit(order):
    rng = np.random.default_rng(11)
    n, block = 3000, 250
    e = np.zeros(n)
    w = rng.standard_normal(n)
    for t in range(2, n):   # a coloured disturbance
        e[t] = 1.2 * e[t - 1] - 0.5 * e[t - 2] + w[t]
    psi = np.sin(np.arange(n) / 7.0) + 0.3 * rng.standard_normal(n)
    e[1700:] += psi[1700:]
    weight = np.ones(n)
    weight[:60] = 0.0
    parity = (np.arange(n) // block) % 2
    folds = [weight * (parity == 0), weight * (parity == 1)]
    onsets = np.array([0, 500, 1000, 1700, 2200])
    gains = RefittedNoise(e, folds, onsets, order).gains(psi)
    rows = [f > 0 for f in folds]
    for i, k in enumerate(onsets):
        for fold in (0, 1):
            train, test = rows[fold], rows[1 - fold]
            nominal = numpy_refitted(e, np.zeros(n), n, train, test, order)
            cand = numpy_refitted(e, psi, k, train, test, order)
            assert gains.in_fold[i, fold] == pytest.approx(train.sum() * np.log(nominal[0] / cand[0]), rel=1e-8, abs=1e-6)
            assert gains.held_out[i, fold] == pytest.approx(test.sum() * np.log(nominal[1] / cand[1]), rel=1e-8, abs=1e-6)
    # the onset where the term was switched on explains most
    assert np.argmax(gains.held_out.sum(axis=1)) == 3
    # a term that is zero changes nothing
    none = RefittedNoise(e, folds, onsets, order).gains(np.zeros(n))
    assert np.allclose(none.in_fold, 0.0, atol=1e-9) and np.allclose(none.held_out, 0.0, atol=1e-9)


def test_refitted_noise_rejects_inconsistent_input():
    e = np.random.default_rng(0).standard_normal(500)
    folds = [np.ones(500), np.zeros(500)]   # everything in one fold
    with pytest.raises(ValueError, match="both folds"):
        RefittedNoise(e, [np.ones(500), np.ones(500)], np.array([0, 100]))
    with pytest.raises(ValueError, match="fold weights must have the length"):
        RefittedNoise(e, [np.ones(10), np.zeros(10)], np.array([0]))
    with pytest.raises(ValueError, match="increasing"):
        RefittedNoise(e, folds, np.array([100, 50]))
    with pytest.raises(ValueError, match="length"):
        RefittedNoise(e, folds, np.array([0])).gains(np.zeros(10))
    # a fold with no rows cannot score anything: every candidate loses, nothing raises
    gains = RefittedNoise(e, folds, np.array([0, 100])).gains(e)
    assert np.all(gains.held_out == -np.inf) and np.all(gains.in_fold == -np.inf)


def _case(family, seed):
    spec, expect = families.family(family).draw(seed, effect="input_nonlinearity")
    linear = copy.deepcopy(spec)
    linear["events"] = [ev for ev in linear["events"] if ev["type"] != "actuator"]
    actuator = next(ev for ev in spec["events"] if ev["type"] == "actuator")
    return spec, linear, actuator


@pytest.mark.parametrize("family, seed, kind, size_key, truth_key", [
    ("mpc_2x2", 19, "deadband", "width", "deadband"),      # positioner deadband on an MV driving two outputs
    ("mpc_siso", 3, "stick_slip", "S", "stiction_s"),      # two-parameter stick-slip
    ("mpc_siso", 13, "saturation", None, None),           # MV limited to a band around its target
    # bands the MV leaves for good: the valve pinned at a limit fits about as well as a gain of
    # 0.06x (2x2) or 0.14x (SISO), and a channel switched off is the actuator's doing (process.DEAD_CHANNEL)
    ("mpc_2x2", 3, "saturation", None, None),
    ("mpc_siso", 5, "saturation", None, None),
])
def test_actuator_that_sets_in_is_named_and_a_linear_valve_is_not(family, seed, kind, size_key, truth_key):
    spec, linear, actuator = _case(family, seed)
    model = nominal_model(spec)
    res = diagnose(model, simulate(spec))
    top = res.findings[0]
    assert (top.effect, top.input, top.estimate["kind"]) == ("input_nonlinearity", actuator["input"], kind)
    # an actuator shows only once the input moves across it: within two 1 h segments
    tolerance = 2 * 3600.0
    if size_key is not None:
        assert abs(top.onset_s - actuator["time_s"]) < tolerance
        assert top.estimate[size_key] == pytest.approx(actuator[truth_key], rel=0.15)
    else:   # a limit the input has not reached yet changes nothing: the onset is an upper bound
        assert top.onset_s < actuator["time_s"] + tolerance
        # once the input has run out of the band and stays pinned, the data fix the band only
        # loosely (any band it left at that time explains the same): the bands overlap
        assert top.estimate["lower"] < actuator["max"] and top.estimate["upper"] > actuator["min"]
    control = diagnose(model, simulate(linear))
    assert not any(f.effect == "input_nonlinearity" for f in control.findings)


@pytest.mark.parametrize("family, seed", [("mpc_2x2", 1), ("mpc_2x2_spiky", 2)])
def test_a_deadband_between_the_width_grid_points_is_found_at_its_width(family, seed):
    # Tuning draws whose deadband lies between two grid widths (thirds of an octave of the
    # median move): a width 2 % off loses most of the fit, so nothing was found before the
    # grid's best width of each kind was refined (ActuatorSearch.best_hysteresis).
    spec, _, actuator = _case(family, seed)
    res = diagnose(nominal_model(spec), simulate(spec))
    top = res.findings[0]
    assert (top.effect, top.input, top.estimate["kind"]) == ("input_nonlinearity", actuator["input"], "deadband")
    assert top.estimate["width"] == pytest.approx(actuator["deadband"], rel=0.03)
    assert abs(top.onset_s - actuator["time_s"]) < 3600.0


def test_a_channel_all_but_switched_off_says_a_valve_does_that_too():
    """A valve pinned in a band far narrower than the MV's moves (mpc_2x2_clip seed 19: u2
    limited to +-0.2 around 47.4, the MPC winding up to 133) fits as well as a gain near 0 of
    its channel, and the actuator candidates lose to it; the gain finding then says that a
    stuck or pinned valve reads the same (process.DEAD_CHANNEL)."""
    spec, _, actuator = _case("mpc_2x2_clip", 19)
    res = diagnose(nominal_model(spec), simulate(spec))
    top = next(f for f in res.findings if f.effect in PROCESS_EFFECTS)
    assert (top.effect, top.input) == ("gain", actuator["input"])
    assert abs(top.estimate["gain_ratio"]) < DEAD_CHANNEL
    assert "has all but stopped acting on" in top.explanation and "valve stuck or pinned" in top.explanation
    gain, _ = families.family("mpc_2x2_clip").draw(19, effect="gain")   # the same loop, a gain x 0.5-2
    ordinary = diagnose(nominal_model(gain), simulate(gain))
    assert any(f.effect == "gain" for f in ordinary.findings)
    assert not any("stopped acting" in f.explanation for f in ordinary.findings)


def test_search_beyond_the_cost_budget_is_skipped_with_a_note_unless_asked(monkeypatch):
    from mpmpp.cli import build_parser
    from mpmpp.commands.diagnose import length_options
    from mpmpp.diagnose import actuator

    spec, _, event = _case("mpc_siso", 3)
    model, data = nominal_model(spec), simulate(spec)
    monkeypatch.setattr(actuator, "SEARCH_WORK", len(data) - 1)   # this record is one row over
    skipped = diagnose(model, data)
    assert not any(f.effect == "input_nonlinearity" for f in skipped.findings)
    assert any("not searched" in note and "--actuator-search" in note for note in skipped.notes)
    asked = diagnose(model, data, actuator_search=True)
    assert asked.findings[0].effect == "input_nonlinearity" and asked.findings[0].input == event["input"]
    args = build_parser().parse_args(["diagnose", "m.json", "d.csv", "--actuator-search"])
    assert length_options(args)["actuator_search"] is True
    args = build_parser().parse_args(["diagnose", "m.json", "d.csv"])
    assert length_options(args)["actuator_search"] is None
