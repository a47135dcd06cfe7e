"""The diagnosis's fast kernels against plain NumPy implementations of the same equations:
the cross-validated onset scan, the step + ramp trend fit over all onsets, and the drift and
delayed-channel responses built from one response per family; the grid refinement against an
analytic minimum."""
import dataclasses
import math

import numpy as np
import pytest
from scipy.stats import chi2

import mpmpp
from mpmpp import TransferFunction, _core
from mpmpp.diagnose.pipeline import diagnosis_signals
from mpmpp.diagnose.plots import rolling_rms
from mpmpp.diagnose import process
from mpmpp.diagnose.responses import ShapeResponses
from mpmpp.diagnose.shapes import COUPLING_DELAYS, DELAY_GRID_EFFECTS, first_order_with_time_constant, process_shapes
from mpmpp.diagnose.refine import neighbours, refine
from mpmpp.diagnose.trend import trend_fit
from mpmpp.diagnose.whitening import disturbance_nuisance, output_residual

import closed_loop_case as loop
from example_cases import MISSING_COUPLING, load_case
from trend_reference import brute_trend


def brute_fits(r, r_without, psi, weight, min_segment, step, held=None):
    """(onset, statistic, theta) for every grid onset; with ``held`` theta is not fitted but
    held at that value."""
    for k in [0, *range(min_segment, len(r) - min_segment + 1, step)]:
        w = weight[k:]
        pp = np.sum(w * psi[k:] ** 2)
        theta = held if held is not None else (np.sum(w * r_without[k:] * psi[k:]) / pp if pp > 0 else 0.0)
        yield k, np.sum(w * (r[k:] ** 2 - (r_without[k:] - theta * psi[k:]) ** 2)), theta


def brute_statistics(r, r_without, psi, weight, min_segment, step):
    return [(k, stat) for k, stat, _ in brute_fits(r, r_without, psi, weight, min_segment, step)]


def brute_scan(r, r_without, psi, weight, min_segment, step):
    best = None
    for fit in brute_fits(r, r_without, psi, weight, min_segment, step):
        if best is None or fit[1] > best[1]:
            best = fit
    return best


@pytest.mark.parametrize("late_start", [False, True])
def test_cross_validated_scan_matches_numpy(late_start):
    rng = np.random.default_rng(1)
    n = 900
    psi = rng.standard_normal(n)
    r_without = np.where(np.arange(n) >= 500, 0.6 * psi, 0.0) + rng.standard_normal(n)
    r = r_without - 0.2 * psi
    if late_start:   # a drift: no nominal channel, the candidate starts at sample 430
        psi[:430] = 0.0
        r = r_without
    weight = (rng.random(n) > 0.05).astype(float)
    parity = (np.arange(n) // 100) % 2
    folds = [weight * (parity == 0), weight * (parity == 1)]
    cv = _core.scan_onset_cross_validated(r, r_without, psi, weight, (parity == 1).astype(float), 60, 7)
    full = brute_scan(r, r_without, psi, weight, 60, 7)
    assert cv.full.onset == full[0]
    assert cv.full.statistic == pytest.approx(full[1], rel=1e-10)
    assert cv.full.theta == pytest.approx(full[2], rel=1e-10)
    for k in (0, 1):
        # held-out blocks leave runs of onsets with identical sums (exact ties): the scan takes
        # the latest of them (the fold cannot tell where inside the other fold's block the
        # change starts, so the held-out drop counts only from where the fold saw it)
        _, stat, _ = brute_scan(r, r_without, psi, weight * folds[k], 60, 7)
        on = cv.folds[k].onset
        assert cv.folds[k].statistic == pytest.approx(stat, rel=1e-10)
        tied = [j for j, s in brute_statistics(r, r_without, psi, weight * folds[k], 60, 7)
                if s == pytest.approx(stat, rel=1e-10)]
        assert on == max(tied)
        w = (weight * folds[k])[on:]
        theta = np.sum(w * r_without[on:] * psi[on:]) / np.sum(w * psi[on:] ** 2)
        assert cv.folds[k].theta == pytest.approx(theta, rel=1e-10)
        test = (weight * folds[1 - k])[on:]
        heldout = np.sum(test * (r[on:] ** 2 - (r_without[on:] - theta * psi[on:]) ** 2))
        assert cv.heldout[k] == pytest.approx(heldout, rel=1e-9, abs=1e-9)


def numpy_cross_validated(r, r_without, psi, weight, odd, begin, min_segment, step, penalty=0.0, held=None):
    """(full (onset, statistic, theta), per fold (onset, statistic, theta, held-out drop)) of
    the scan on samples from ``begin`` on, onsets as sample indices (latest of tied onsets); an
    onset after ``begin`` competes with its statistic less ``penalty``; ``held``: theta held at
    that value."""
    tail = slice(begin, None)
    folds = [weight * (odd == 0), weight * (odd != 0)]

    def charged(fit):
        return fit[1] - (penalty if fit[0] > 0 else 0.0)

    fits = list(brute_fits(r[tail], r_without[tail], psi[tail], weight[tail], min_segment, step, held))
    onset, stat, theta = max(fits, key=charged)    # the first of tied maxima
    per_fold = []
    for k in (0, 1):
        fits = list(brute_fits(r[tail], r_without[tail], psi[tail], folds[k][tail], min_segment, step, held))
        best = max(charged(f) for f in fits)
        on, s, th = max((f for f in fits if charged(f) == pytest.approx(best, rel=1e-10)), key=lambda f: f[0])
        on += begin
        test = folds[1 - k][on:]
        heldout = np.sum(test * (r[on:] ** 2 - (r_without[on:] - th * psi[on:]) ** 2))
        per_fold.append((on, s, th, heldout))
    return (begin + onset, stat, theta), per_fold


def nuisance_case(rng, n, width):
    """(Z, weight, odd, S): the level and (width - 1) / 2 step + ramp disturbance columns,
    jittered, about 5 % of the samples left out, folds of 100 samples, and the weighted
    least-squares solve of Z."""
    t = np.arange(n)
    z = np.column_stack([np.ones(n)] + [np.where(t >= k, d, 0.0) for k in (300, 610)[: (width - 1) // 2]
                                         for d in (1.0, (t - k) / 100.0)])
    z += 0.1 * rng.standard_normal(z.shape)
    weight = (rng.random(n) > 0.05).astype(float)
    odd = ((t // 100) % 2 == 1) * weight
    solve = np.linalg.pinv((z * weight[:, None]).T @ z) @ (z * weight[:, None]).T
    return z, weight, odd, solve


@pytest.mark.parametrize("held", [None, 1.0, 0.7])
@pytest.mark.parametrize("case", ["full", "late_start", "nominal", "own_weight", "begin", "penalty", "snap"])
@pytest.mark.parametrize("width", [1, 5])
def test_projected_scan_matches_numpy(case, width, held):
    """ProjectedOnsetScan: the candidate projected beside nuisance columns Z inside the scan
    (psi = x - Z S x), against NumPy projecting it first and scanning by brute force; the
    late start exercises the sums taken from the nuisance's own before the candidate starts.
    ``held``: fit_holding_scale, whose first fit is ``fit``'s and whose second holds theta."""
    rng = np.random.default_rng(width)
    n, begin = 900, (130 if case == "begin" else 0)
    t = np.arange(n)
    z, weight, odd, solve = nuisance_case(rng, n, width)
    x = rng.standard_normal(n)
    change = 500
    if case == "late_start":   # a drift from 430; its projection carries the change from 200
        x = np.where(t >= 430, 1.0 + x, 0.0)
        change = 200
    psi = x - z @ (solve @ x)
    r = z @ rng.standard_normal(width) + np.where(t >= change, psi, 0.0) + rng.standard_normal(n)
    r -= z @ (solve @ r)
    nominal = 0.3 * (rng.standard_normal(n) - z @ (solve @ rng.standard_normal(n))) if case == "nominal" else None
    own = weight * (rng.random(n) > 0.1) if case == "own_weight" else None
    r_without = r if nominal is None else r + nominal
    penalty = 0.0
    if case in ("penalty", "snap"):   # a charge of half / twice what the best onset gains over the start
        stats = [st for _, st in brute_statistics(r, r_without, psi, weight, 60, 7)]
        penalty = (0.5 if case == "penalty" else 2.0) * (max(stats) - stats[0])
        assert penalty > 1.0
    scan = _core.ProjectedOnsetScan(r, weight, odd, z, solve, begin, 60, 7, penalty)
    cv = scan.fit(x, nominal, own)
    if held is not None:
        free, held_fit = scan.fit_holding_scale(x, nominal, own, held)
        assert (free.full.onset, free.full.statistic, free.heldout) == (cv.full.onset, cv.full.statistic, cv.heldout)
        cv = held_fit
    w = weight if own is None else own
    full, folds = numpy_cross_validated(r, r_without, psi, w, odd, begin, 60, 7, penalty, held)
    if case == "late_start":
        assert full[0] < 430 and max(f[0] for f in folds) < 430
    if case in ("penalty", "snap") and held is None:
        assert (full[0] == begin) == (case == "snap")
    assert cv.full.onset == full[0]
    assert cv.full.statistic == pytest.approx(full[1], rel=1e-9)
    assert cv.full.theta == pytest.approx(full[2], rel=1e-9)
    for k in (0, 1):
        on, stat, theta, heldout = folds[k]
        assert cv.folds[k].onset == on
        assert cv.folds[k].statistic == pytest.approx(stat, rel=1e-9)
        assert cv.folds[k].theta == pytest.approx(theta, rel=1e-9)
        assert cv.heldout[k] == pytest.approx(heldout, rel=1e-8, abs=1e-8)


def level_step_fits(r, r_without, psi, q_of, weight, begin, min_segment, step, held=None):
    """(onset, statistic, theta, c) for every grid onset k from ``begin``: weighted least squares
    of r_without on [psi, q_k] after k and of r on q_k before it (rows from ``begin``), the
    statistic the drop of the squared error against r; ``held``: theta held at that value."""
    n = len(r)
    t = np.arange(n)
    for k in [begin, *range(begin + min_segment, n - min_segment + 1, step)]:
        q = q_of(k)
        rows = t >= begin
        after = t >= k
        target = np.where(after, r_without, r)[rows]
        design = np.column_stack([np.where(after, psi, 0.0), q])[rows]
        sw = np.sqrt(weight[rows])
        if held is None:
            coef = np.linalg.lstsq(design * sw[:, None], target * sw, rcond=None)[0]
        else:
            target = target - held * design[:, 0]
            coef = np.array([held, np.linalg.lstsq(design[:, 1:] * sw[:, None], target * sw, rcond=None)[0][0]])
            target = target + held * design[:, 0]
        stat = np.sum(weight[rows] * r[rows] ** 2) - np.sum(weight[rows] * (target - design @ coef) ** 2)
        yield k, stat, coef[0], coef[1]


@pytest.mark.parametrize("held", [None, 1.0])
@pytest.mark.parametrize("case", ["full", "nominal", "begin", "penalty"])
@pytest.mark.parametrize("width", [1, 5])
def test_level_step_scan_matches_least_squares(case, width, held):
    """ProjectedOnsetScan.fit_with_level_step: the channel fitted with a level step at its onset,
    the step projected beside the nuisance columns (before the onset too), against NumPy least
    squares of the same model at every grid onset; each fold's fit scored on the other fold.
    ``held``: the second fit, the step alone with the channel scale held at 1."""
    rng = np.random.default_rng(10 + width)
    n, begin = 900, (130 if case == "begin" else 0)
    t = np.arange(n)
    z, weight, odd, solve = nuisance_case(rng, n, width)
    level = 0.8 + 0.05 * rng.standard_normal(n)      # a whitened constant, not quite constant

    def project(v):
        return v - z @ (solve @ v)

    x = rng.standard_normal(n)
    psi = project(x)

    def q_of(k):
        return project(np.where(t >= k, level, 0.0))

    r = project(z @ rng.standard_normal(width) + np.where(t >= 500, 0.6 * psi, 0.0) + 1.5 * q_of(500)
                + rng.standard_normal(n))
    nominal = project(0.3 * rng.standard_normal(n)) if case == "nominal" else None
    r_without = r if nominal is None else r + nominal
    penalty = 0.0
    if case == "penalty":
        stats = [f[1] for f in level_step_fits(r, r_without, psi, q_of, weight, begin, 60, 7)]
        penalty = 0.5 * (max(stats) - stats[0])
        assert penalty > 1.0
    cv = _core.ProjectedOnsetScan(r, weight, odd, z, solve, begin, 60, 7, penalty).fit_with_level_step(
        x, level, nominal)[0 if held is None else 1]

    def best(w):
        fits = list(level_step_fits(r, r_without, psi, q_of, w, begin, 60, 7, held))
        return max(fits, key=lambda f: (f[1] - (penalty if f[0] > begin else 0.0), f[0]))

    onset, stat, theta, c = best(weight)
    assert (cv.full.onset, cv.full.statistic, cv.full.theta, cv.full.step) == (
        onset, pytest.approx(stat, rel=1e-9), pytest.approx(theta, rel=1e-9), pytest.approx(c, rel=1e-9))
    # the onset set: every grid onset whose charged statistic is within the chi-square 95 % point
    # of the best, by its first and last onsets, each widened to the grid onset beyond it (not
    # back across the grid's first gap to ``begin``)
    assert _core.ONSET_SET_DROP == pytest.approx(chi2.ppf(0.95, 1), rel=1e-3)
    grid = [(f[0], f[1] - (penalty if f[0] > begin else 0.0))
            for f in level_step_fits(r, r_without, psi, q_of, weight, begin, 60, 7, held)]
    inside = [i for i, (_, s) in enumerate(grid) if s >= max(s for _, s in grid) - _core.ONSET_SET_DROP]
    first, last = min(inside), max(inside)
    first, last = first - 1 if first > 1 else first, min(last + 1, len(grid) - 1)
    assert (cv.full.onset_first, cv.full.onset_last) == (grid[first][0], grid[last][0])
    assert cv.full.onset_first < cv.full.onset < cv.full.onset_last
    if case == "full" and held is None:
        assert abs(onset - 500) <= 7 and abs(c - 1.5) < 0.3 and abs(theta - 0.6) < 0.2
    folds = [weight * (odd == 0), weight * (odd != 0)]
    for k in (0, 1):
        on, stat, theta, c = best(folds[k])
        assert (cv.folds[k].onset, cv.folds[k].statistic, cv.folds[k].theta, cv.folds[k].step) == (
            on, pytest.approx(stat, rel=1e-9), pytest.approx(theta, rel=1e-9), pytest.approx(c, rel=1e-9))
        q, after = q_of(on), t >= on
        fitted = np.where(after, r_without - theta * psi, r) - c * q
        test = folds[1 - k] * (t >= begin)
        assert cv.heldout[k] == pytest.approx(np.sum(test * (r ** 2 - fitted ** 2)), rel=1e-8, abs=1e-8)


def test_projected_scan_rejects_mismatched_lengths_and_a_non_finite_scale():
    n = 300
    z, solve = np.ones((n, 1)), np.full((1, n), 1.0 / n)
    with pytest.raises(ValueError, match="same length"):
        _core.ProjectedOnsetScan(np.zeros(n), np.ones(n - 1), np.zeros(n), z, solve, 0, 60, 7)
    scan = _core.ProjectedOnsetScan(np.zeros(n), np.ones(n), np.zeros(n), z, solve, 0, 60, 7)
    with pytest.raises(ValueError, match="length of r"):
        scan.fit(np.zeros(n + 1))
    with pytest.raises(ValueError, match="held channel scale must be finite"):
        scan.fit_holding_scale(np.zeros(n), scale=float("nan"))
    with pytest.raises(ValueError, match="length of r"):
        scan.fit_with_level_step(np.zeros(n), np.ones(n - 1))


@pytest.mark.parametrize("seed", [0, 1])
def test_trend_fit_matches_least_squares_per_onset(seed):
    rng = np.random.default_rng(seed)
    n = 3000
    e = rng.standard_normal(n) + 0.002 * np.maximum(np.arange(n) - 1700, 0) + 0.5 * (np.arange(n) > 2200)
    ok = np.ones(n, bool)
    ok[:60] = False
    ok[900:1000] = False
    hinv = TransferFunction([1.0, -0.3], [1.0, 0.5]).inverse()
    fit = trend_fit(e, ok, hinv, 0, 40, 120)
    onset, drop = brute_trend(e, ok, hinv, 0, 40, 120)
    assert fit.onset == onset
    assert fit.drop == pytest.approx(drop, rel=1e-8)


def test_drift_responses_match_direct_whitening():
    # a noise change half-way: two whitening pieces, so drifts start in either piece
    data = loop.simulate(n=8000, seed=2, onset=4000, noise_den_after=[1.0, -0.9])
    sig = diagnosis_signals(loop.model(), data).sig
    out = output_residual(sig, 0, 720, 0, 720)
    assert len(out.pieces) == 2
    # beside the output's level and a step + ramp from the noise change on: responses projected
    nuisance = disturbance_nuisance(out, [4000])
    responses = ShapeResponses(out, nuisance)
    hour = 3600.0 / sig.sample_time_s
    n = len(sig.time_s)
    drifts = [s for s in process_shapes(sig, 0) if s.kind == "drift"]
    assert {s.drift_form for s in drifts} == {"ramp", "step"}
    for s in drifts:
        t = np.maximum(np.arange(n) - int(s.label), 0.0)
        drive = t / hour if s.drift_form == "ramp" else (t > 0).astype(float)
        direct = nuisance.project(out.whiten(out.channel_response(s.shape, drive)))
        np.testing.assert_allclose(responses.whitened(s).psi, direct, rtol=0, atol=1e-9)


@pytest.mark.parametrize("with_channel", [True, False])
def test_delayed_responses_match_direct_whitening(with_channel):
    # two data segments (a gap) and a noise split inside the first: pieces that start a
    # segment and one that starts inside a segment
    data = loop.simulate(n=8000, seed=2, onset=4000, noise_den_after=[1.0, -0.9], w_gain=1.0)
    data.loc[6000:6300, "y"] = np.nan
    model = loop.model() if with_channel else mpmpp.Model(
        "no channel", loop.TS, ["u"], ["y"], {}, {"y": loop.model().noise("y")})
    sig = diagnosis_signals(model, data).sig
    out = output_residual(sig, 0, 720, 0, 720)
    assert len(sig.segments) == 2 and len(out.pieces) == 3
    nuisance = disturbance_nuisance(out, [])
    responses = ShapeResponses(out, nuisance)
    shapes = [s for s in process_shapes(sig, 0) if s.effect in DELAY_GRID_EFFECTS]
    assert {s.effect for s in shapes} == ({"delay", "unmodeled_input"} if with_channel
                                          else {"missing_coupling", "unmodeled_input"})
    for s in shapes:
        direct = nuisance.project(out.whiten(out.channel_response(s.shape, np.nan_to_num(s.drive))))
        np.testing.assert_allclose(responses.whitened(s).psi, direct, rtol=0, atol=1e-9)


def test_responses_of_short_lived_shapes_are_their_own():
    # the refinement's shapes (a time-constant factor between grid points) live only while they
    # are fitted; CPython hands a freed shape's address to the next, so a cache keyed by the
    # shape's id returned an earlier factor's response
    data = loop.simulate(n=6000, seed=4)
    sig = diagnosis_signals(loop.model(), data).sig
    out = output_residual(sig, 0, 720, 0, 720)
    responses = ShapeResponses(out, disturbance_nuisance(out, []))
    (base,) = [s for s in process_shapes(sig, 0) if s.effect == "time_constant" and s.label == 2.0]
    for factor in np.linspace(1.6, 2.9, 12):
        shape = dataclasses.replace(base, shape=first_order_with_time_constant(base.nominal, factor))
        direct = out.whiten(out.channel_response(shape.shape, np.nan_to_num(shape.drive)))
        np.testing.assert_array_equal(responses.response(shape), direct)


def test_coarse_drift_search_finds_the_exhaustive_searchs_drift(monkeypatch):
    # 50 h at 5 s: 98 drift onsets per form, fitted every 3rd and then around the leaders;
    # a ramp from 29 h on, between two onsets of the grid
    data = loop.simulate(n=36000, seed=3, onset=21000, drift_rate=2e-5)
    sig = diagnosis_signals(loop.model(), data).sig
    out = output_residual(sig, 0, 720, 0, 720)
    nuisance = disturbance_nuisance(out, [])
    responses = ShapeResponses(out, nuisance)
    logn = math.log(len(sig.time_s))
    search = process._Search(out, process_shapes(sig, 0), 0, 720, 12, logn, {}, 0.0)
    scan = search.scan(nuisance.project(out.r), responses)
    coarse = search._drift_fits(scan, responses)
    monkeypatch.setattr(process, "DRIFT_ONSETS_EXHAUSTIVE", 10**6)
    every = search._drift_fits(scan, responses)
    assert len(every) == 2 * 98 and len(coarse) < len(every) / 2
    (found,), (best,) = process._best_per_channel(coarse, logn), process._best_per_channel(every, logn)
    assert (found.shape.label, found.shape.drift_form) == (best.shape.label, best.shape.drift_form)
    assert found.onset == best.onset and found.heldout == best.heldout
    assert best.shape.drift_form == "ramp" and abs(best.shape.label - 21000) <= 360


def test_line_search_refines_level_by_level_to_the_peaks(monkeypatch):
    # two lines of 300 shapes with one smooth peak each (at 137 and 251; fold 1 peaks at 20):
    # stride 14 fits every 14th, then every 5th, 2nd and 1st shape around the leaders
    peaks = {0: 137, 1: 251}
    fitted = []

    def fake_fit(scan, shape, responses):
        k, i = shape
        fitted.append((k, i))
        stat = 100.0 - abs(i - peaks[k]) / (2.0 if k == 0 else 1.0)
        folds = [process.FoldFit(stat, 0.0, 1.0), process.FoldFit(90.0 - abs(i - 20) if k == 0 else 0.0, 0.0, 1.0)]
        return process.Fit(shape, 0, stat, 0.0, 1.0, 0.1, folds, 0.0)

    monkeypatch.setattr(process, "_fit_shape", fake_fit)
    lines = [[(k, i) for i in range(300)] for k in (0, 1)]
    fits = process._line_fits(None, None, lines, 14)
    assert len(fitted) == len(set(fitted)) == len(fits) and len(fits) < 300 / 4
    for k, peak in peaks.items():
        assert max((f for f in fits if f.shape[0] == k), key=lambda f: f.statistic).shape == (k, peak)
    assert max(fits, key=lambda f: f.folds[1].statistic).shape == (0, 20)
    fitted.clear()
    assert len(process._line_fits(None, None, lines, 1)) == 600


def test_coarse_coupling_search_finds_the_exhaustive_searchs_channel(monkeypatch):
    # the example's missing coupling: every third delay per pole (1, 4, 7, ...), then around
    # the leaders, one of which (fold 0's) lies between the coarse grid's delays
    model, data, hidden = load_case(MISSING_COUPLING)
    sig = diagnosis_signals(model, data).sig
    i = sig.outputs.index(hidden["output"])
    out = output_residual(sig, i, 720, 0, 720)
    nuisance = disturbance_nuisance(out, [])
    responses = ShapeResponses(out, nuisance)
    logn = math.log(len(sig.time_s))
    shapes = [s for s in process_shapes(sig, i) if s.column == hidden["input"]]
    assert {s.effect for s in shapes} == {"missing_coupling"}
    search = process._Search(out, shapes, 0, 720, 12, logn, {}, 0.0)
    scan = search.scan(nuisance.project(out.r), responses)
    stride = process.COUPLING_DELAY_STRIDE
    coarse = search._coupling_fits(scan, responses, shapes)
    monkeypatch.setattr(process, "COUPLING_DELAY_STRIDE", 1)
    every = search._coupling_fits(scan, responses, shapes)
    assert len(every) == len(shapes) and len(coarse) < len(every) / 2

    def leaders(fits):   # the shapes _best_per_channel picks: on all data and on each fold
        picks = [max(fits, key=lambda f: f.statistic)]
        picks += [max(fits, key=lambda f, k=k: f.folds[k].statistic) for k in (0, 1)]
        return [(f.shape.label, f.shape.shape.den[1], f.onset) for f in picks]

    assert leaders(coarse) == leaders(every)
    assert any((label - COUPLING_DELAYS[0]) % stride for label, _, _ in leaders(every))
    (found,), (best,) = process._best_per_channel(coarse, logn), process._best_per_channel(every, logn)
    assert found.heldout == best.heldout and found.theta == best.theta


def test_rolling_rms_matches_a_plain_window():
    rng = np.random.default_rng(3)
    x = rng.standard_normal(200)
    x[50:55] = np.nan
    got = rolling_rms(x, 21)
    for t in range(200):
        window = x[max(t - 10, 0):t + 11]
        window = window[np.isfinite(window)]
        expected = np.sqrt(np.mean(window**2)) if len(window) > 10 else np.nan
        assert got[t] == pytest.approx(expected, rel=1e-12, nan_ok=True)


@pytest.mark.parametrize("truth,best", [(2.37, 2.0), (0.41, 0.33), (4.2, 3.0), (0.72, 0.67)])
def test_refine_finds_the_analytic_minimum_between_grid_neighbours(truth, best):
    """A criterion with its minimum at ``truth`` (a smooth, asymmetric bowl): the refined value
    is the analytic minimiser, searched only between the grid neighbours of ``best``."""
    grid = (0.33, 0.5, 0.67, 0.8, 1.25, 1.5, 2.0, 3.0)
    lo, hi = neighbours(grid, best, 0.2, 5.0)
    assert lo < truth < hi
    value = refine(lambda x: (math.log(x) - math.log(truth)) ** 2, grid, best, 0.2, 5.0)
    assert value == pytest.approx(truth, rel=2e-3)


def test_refine_keeps_the_grid_value_when_nothing_is_better():
    grid = (0.5, 1.0, 2.0)
    assert refine(lambda x: 0.0, grid, 1.0, 0.1, 4.0) == 1.0          # flat: no improvement
    assert refine(lambda x: abs(x - 1.0), grid, 1.0, 0.1, 4.0) == 1.0   # minimum on the grid point
    assert neighbours(grid, 0.5, 0.1, 4.0) == (0.1, 1.0)
    assert neighbours(grid, 2.0, 0.1, 4.0) == (1.0, 4.0)
