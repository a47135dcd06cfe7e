"""diagnose on valid data that used to break it: models without a noise model, held-out folds
left (nearly) empty after a late onset, user-style PI loops. The answer is a finding-free
result or a note about the data, never an exception."""
import warnings

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

import mpmpp
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose
from mpmpp.diagnose.pipeline import diagnosis_signals
from mpmpp.diagnose.result import InsufficientData
from mpmpp.diagnose.laguerre import BASIS_LEAD
from mpmpp.diagnose import whitening
from mpmpp.diagnose.whitening import (AMPLIFYING, INPUT_BASIS_FUNCTIONS, NOISE_ORDER, TREND_GRID, disturbance_ar,
                                      masked_ar)
from mpmpp.evaluate import nominal_model
from mpmpp.foptd import foptd_parameters
from mpmpp.simulate import simulate
from mpmpp import families
from mpmpp.update import update

import closed_loop_case as loop
from trend_reference import brute_trend


def model_without_noise():
    return mpmpp.Model("test loop, no noise model", loop.TS, ["u"], ["y"],
                       {"y": {"u": mpmpp.TransferFunction(*loop.G)}})


def pi_loop(n, seed, gain_after=1.0, ts=1.0, k=2.0, tau=60.0, dead=10, kc=0.2, ti=60.0):
    """A user-style PI loop: first-order-plus-dead-time plant, velocity-form PI, setpoint steps
    every 30 min, a slowly wandering disturbance; the plant gain times ``gain_after`` from the
    middle on. Returns (data, the hand-written FOPTD model without a noise model)."""
    rng = np.random.default_rng(seed)
    a = np.exp(-ts / tau)
    e = rng.standard_normal(n)
    v = np.zeros(n)
    for t in range(1, n):
        v[t] = 0.99 * v[t - 1] + 0.02 * e[t]
    v += 0.01 * rng.standard_normal(n)
    phase = (np.arange(n) // int(1800 / ts)) % 3
    sp = np.where(phase == 1, 1.0, np.where(phase == 2, -0.5, 0.0))
    u, x, y = np.zeros(n), np.zeros(n), np.zeros(n)
    err_prev = 0.0
    for t in range(n):
        gain = k * (gain_after if t >= n // 2 else 1.0)
        x[t] = a * x[t - 1] + gain * (1 - a) * u[t - 1 - dead] if t > dead else 0.0
        y[t] = x[t] + v[t]
        err = sp[t] - y[t]
        u[t] = (u[t - 1] if t else 0.0) + kc * (err - err_prev) + kc * ts / ti * err
        err_prev = err
    data = pd.DataFrame({"time": ts * np.arange(n), "u": u + 50.0, "y": y + 20.0, "y_sp": sp + 20.0})
    model = mpmpp.Model("PI loop", ts, ["u"], ["y"],
                        {"y": {"u": mpmpp.TransferFunction([k * (1 - a)], [1.0, -a], dead + 1)}})
    return data, model


# ---- no noise model --------------------------------------------------------------------------

@pytest.mark.parametrize("seed", [0, 1])
def test_no_noise_model_and_no_change_gives_no_finding(seed):
    res = diagnose(model_without_noise(), loop.simulate(n=8000, seed=seed))
    assert res.findings == []
    assert any("no noise model" in n and "estimated" in n for n in res.notes)
    assert "notes" in res.to_dict()


def test_no_noise_model_gain_change_is_a_gain_change():
    res = diagnose(model_without_noise(), loop.simulate(n=8000, seed=3, onset=4000, gain=2.0))
    assert res.findings and res.findings[0].effect == "gain"
    assert res.findings[0].estimate["gain_ratio"] == pytest.approx(2.0, rel=0.2)
    assert not any(f.effect == "noise_change" for f in res.findings)
    # the figures' after-update error is the one update reports on (odd blocks after onset)
    after = res.residuals_after["F1"]
    rows = ((np.arange(8000) // 720) % 2 == 1) & (res.time_s >= res.findings[0].onset_s) & np.isfinite(after)
    assert np.sqrt(np.mean(after[rows] ** 2)) == pytest.approx(res.findings[0].error_after, rel=1e-9)
    up = update(model_without_noise(), loop.simulate(n=8000, seed=3, onset=4000, gain=2.0), "F1")
    assert up.errors[0].error_after < up.errors[0].error_before
    assert "no noise model" in up.summary()


def test_no_noise_model_reports_no_disturbance_present_from_the_start():
    """A noise model estimated from the record leaves some low-frequency misfit; a "slow drift
    throughout the record" is then the estimate's imperfection, as a noise change throughout
    is (held-out family multi_pi_2x2, seed 382: the model file has no noise model, y2's true
    disturbance is (1 - 0.80 q^-1) / (1 + 0.16 q^-1) e, and a drift throughout on y2 was
    reported at confidence 0.99 beside the scheduled gain change on y1)."""
    from mpmpp import families
    from mpmpp.evaluate import nominal_model
    from mpmpp.simulate import simulate

    spec, _ = families.family("multi_pi_2x2").draw(382, None, "gain")
    res = diagnose(nominal_model(spec), simulate(spec))
    assert any("no noise model" in n for n in res.notes)
    assert not any(f.onset_s == 0.0 and f.effect in ("output_drift", "noise_change") for f in res.findings)
    assert [(f.effect, f.output, f.input) for f in res.findings if f.effect == "gain"] == [("gain", "y1", "u1")]


def test_no_noise_model_real_noise_change_is_found_after_its_onset():
    res = diagnose(model_without_noise(), loop.simulate(n=8000, seed=2, onset=4000, noise_den_after=[1.0, -0.9]))
    assert res.findings and res.findings[0].effect in ("noise_change", "output_drift")
    assert not any(f.effect in PROCESS_EFFECTS for f in res.findings)
    assert abs(res.findings[0].onset_s - 4000 * loop.TS) <= 3600


def laguerre_reference(u, pole, count):
    """Laguerre functions of u (scipy.signal.lfilter): sqrt(1 - a^2) q^-1 / (1 - a q^-1), then
    each through the all-pass (q^-1 - a) / (1 - a q^-1)."""
    x = lfilter([0.0, np.sqrt(1 - pole * pole)], [1.0, -pole], u)
    columns = [x]
    for _ in range(count - 1):
        x = lfilter([-pole, 1.0], [1.0, -pole], x)
        columns.append(x)
    return np.column_stack(columns)


def test_estimated_noise_model_matches_least_squares_reference():
    """H = 1/A from the output error: against a plain NumPy least-squares ARX fit on the same
    rows (AR beside a Laguerre basis of the input from a few samples before its dead time, whose
    coefficients are dropped), and close to
    the true AR(2) disturbance (open loop, white input)."""
    rng = np.random.default_rng(5)
    n = 20000
    u = rng.standard_normal(n)
    e = 0.1 * rng.standard_normal(n)
    v = lfilter([1.0], [1.0, -1.2, 0.5], e)
    num, den, d = loop.G
    x = lfilter(np.r_[np.zeros(d), num], den, u)
    data = pd.DataFrame({"time": loop.TS * np.arange(n), "u": u, "y": x + v})
    prepared = diagnosis_signals(model_without_noise(), data)
    assert prepared.estimated_noise == ["y"]
    h = prepared.sig.noise[0]
    assert np.array_equal(h.num, [1.0]) and len(h.den) == NOISE_ORDER + 1
    # reference: v as deviations less its best step + ramp (one least-squares fit per onset)
    # and its mean, rows after the 60-sample settling, lags 1..NOISE_ORDER
    vd = (x + v) - np.mean(x + v)
    vd = vd - lfilter(np.r_[np.zeros(d), num], den, u - u.mean())
    ok = np.arange(n) >= 60
    k, _ = brute_trend(vd, ok, mpmpp.TransferFunction(), 0, TREND_GRID, 120)
    t = np.arange(n)
    basis = np.column_stack([np.ones(n), t >= k, np.maximum(t - k, 0)])
    coef = np.linalg.lstsq(basis[ok], vd[ok], rcond=None)[0]
    vd = vd - basis[:, 1:] @ coef[1:]
    vd = vd - vd[ok].mean()
    rows = np.arange(60, n)
    lagged = vd[rows[:, None] - np.arange(1, NOISE_ORDER + 1)]
    # the basis: G's pole 0.9, the input delayed to BASIS_LEAD samples before G's delay
    shift = d - BASIS_LEAD
    inputs = laguerre_reference(np.r_[np.zeros(shift), (u - u.mean())[: n - shift]], 0.9, INPUT_BASIS_FUNCTIONS)
    a_ref = np.linalg.lstsq(np.column_stack([lagged, inputs[rows]]), vd[rows], rcond=None)[0][:NOISE_ORDER]
    assert np.allclose(h.den[1:], -a_ref, atol=1e-6)
    assert h.den[1] == pytest.approx(-1.2, abs=0.05) and h.den[2] == pytest.approx(0.5, abs=0.05)
    assert np.all(np.abs(h.den[3:]) < 0.05)


@pytest.mark.parametrize("rate", [2e-4, 1e-3])
def test_estimated_noise_model_does_not_absorb_a_drift(rate):
    """An output drift from the middle of a closed-loop record, no noise model: the AR fitted
    with the drift in it has a root at 0.999 (it differences the drift away, and the
    controller's compensation then posed as a delay / time-constant change at 1e-3 per
    sample). With the best step + ramp removed first, the estimate keeps the disturbance's
    own roots (H = (1 - 0.3q^-1) / (1 + 0.5q^-1): 0.66-0.77 measured), the drift is named and
    no process change is."""
    data = loop.simulate(n=8000, seed=0, onset=4000, drift_rate=rate)
    h = diagnosis_signals(model_without_noise(), data).sig.noise[0]
    assert np.max(np.abs(np.roots(h.den))) < 0.9
    res = diagnose(model_without_noise(), data)
    assert not [f for f in res.findings if f.effect in PROCESS_EFFECTS]
    assert [f.effect for f in res.findings] == ["output_drift"]

@pytest.mark.parametrize("gain", [3.0, 0.5])
def test_estimated_noise_model_is_not_taken_by_a_later_process_change(gain, monkeypatch):
    """A gain change at 10,000 of 16,000 rows, no noise model: the AR of the whole record takes up
    the changed channel's error (its coefficients 0.26-0.33 off the true H^-1 = (1 + 0.5q^-1) /
    (1 - 0.3q^-1) = 1 + 0.8 sum_k (0.3 q^-1)^k), the first part's AR keeps the disturbance's
    own (whitening.first_part_ar), and the gain change is named."""
    truth = np.r_[1.0, [0.8 * 0.3**k for k in range(NOISE_ORDER)]]
    data = loop.simulate(n=16000, seed=0, onset=10000, gain=gain)
    h = diagnosis_signals(model_without_noise(), data).sig.noise[0]
    assert np.max(np.abs(np.asarray(h.den) - truth)) < 0.08
    assert diagnose(model_without_noise(), data).findings[0].effect == "gain"
    monkeypatch.setattr(whitening, "REFERENCE_PARTS", 1)
    whole = diagnosis_signals(model_without_noise(), data).sig.noise[0]
    assert np.max(np.abs(np.asarray(whole.den) - truth)) > 0.2


# ---- degenerate folds and singular fits --------------------------------------------------------

def test_masked_ar_reports_too_little_data_not_a_singular_matrix():
    e = np.random.default_rng(0).standard_normal(500)
    with pytest.raises(InsufficientData):
        masked_ar(e, np.zeros(500, bool))
    with pytest.raises(InsufficientData):
        masked_ar(np.zeros(500), np.ones(500, bool))


def test_masked_ar_beside_an_input_that_never_moves_is_the_plain_ar():
    """An input column that is zero on the rows (a valve held at its limit) leaves the normal
    equations singular: the minimum-norm solution is the AR fitted beside the other columns."""
    rng = np.random.default_rng(1)
    e = lfilter([1.0], [1.0, -0.6], rng.standard_normal(2000))
    moving = rng.standard_normal((2000, 1))
    inputs = np.column_stack([moving, np.zeros(2000)])
    mask = np.arange(2000) >= 10
    with_still = masked_ar(e, mask, 3, inputs)
    assert np.allclose(with_still, masked_ar(e, mask, 3, moving), atol=1e-10)
    rows = np.flatnonzero(mask)
    lagged = e[rows[:, None] - np.arange(1, 4)]
    ref = np.linalg.lstsq(np.column_stack([lagged, moving[rows]]), e[rows], rcond=None)[0]
    assert np.allclose(with_still[1:], -ref[:3], atol=1e-10)
    assert with_still[1] == pytest.approx(-0.6, abs=0.05)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_disturbance_ar_is_the_plain_ar_where_the_one_beside_the_inputs_amplifies(seed):
    """An input that is mostly the error's last sample and a little of the one to come (the
    split of a loop whose input's past is a filter of the error's past, made extreme): the ARX
    puts a_1 near -50 beside it, an AR that alone multiplies the error's variance some 2,500
    times; disturbance_ar gives the plain AR then (NumPy least squares on the lags alone). An
    input independent of the error keeps the AR fitted beside it."""
    rng = np.random.default_rng(seed)
    n = 3000
    s, w = rng.standard_normal(n), rng.standard_normal(n)
    e = s + w
    inputs = (50.0 * np.r_[0.0, e[:-1]] + s)[:, None]
    mask = np.arange(n) >= 20
    rows = np.flatnonzero(mask)
    lagged, target = e[rows[:, None] - np.arange(1, NOISE_ORDER + 1)], e[rows]
    beside = np.linalg.lstsq(np.column_stack([lagged, inputs[rows]]), target, rcond=None)[0][:NOISE_ORDER]
    assert np.sum((target - lagged @ beside) ** 2) > 100 * AMPLIFYING * np.sum(target**2)
    plain = np.linalg.lstsq(lagged, target, rcond=None)[0]
    assert np.allclose(disturbance_ar(e, mask, inputs)[1:], -plain, atol=1e-10)
    independent = rng.standard_normal((n, 2))
    assert np.allclose(disturbance_ar(e, mask, independent), masked_ar(e, mask, NOISE_ORDER, independent), atol=1e-12)
    assert not np.allclose(masked_ar(e, mask, NOISE_ORDER, independent), np.r_[1.0, -plain], atol=1e-10)


def test_an_exact_level_model_under_mpc_without_a_noise_model_gives_no_process_finding():
    """Tuning family mpc_level, seed 8: an exact model with no noise model, an MPC and no
    excitation, the disturbance changes at 9.9 h. The AR(10) estimated beside the input's basis
    left 4.4 times the output error's squared sum and the corrections up to 106 times; the
    whitened error then confirmed a dead time of 3 samples instead of 1 throughout, at 0.99.
    With the plain AR in its place, the noise change alone is named."""
    spec, expect = families.family("mpc_level").draw(8, effect="noise_change")
    res = diagnose(nominal_model(spec), simulate(spec))
    assert not [f for f in res.findings if f.effect in PROCESS_EFFECTS]
    assert res.findings[0].effect == "noise_change"
    assert abs(res.findings[0].onset_s - expect["onset_s"]) <= 3600


def test_change_in_the_last_block_leaves_a_note_not_an_error():
    # 8 h of 1 h blocks; the disturbance changes at the start of the last block, so after the
    # change only one of the two held-out folds has data.
    res = diagnose(loop.model(), loop.simulate(n=5760, seed=0, onset=5040, noise_den_after=[1.0, -0.9]))
    assert not any(f.effect in PROCESS_EFFECTS for f in res.findings)
    assert any("too few held-out rows" in n for n in res.notes)
    assert "note:" in res.summary()


def test_valid_pi_loop_record_gives_an_answer():
    data, model = pi_loop(6 * 3600, seed=1, gain_after=2.0)
    res = diagnose(model, data)
    assert not any(f.effect == "noise_change" and f.onset_s == 0.0 for f in res.findings)
    assert any("no noise model" in n for n in res.notes)


# ---- records cut by lost samples -------------------------------------------------------------

def test_a_record_cut_by_lost_samples_is_diagnosed_not_a_singular_matrix():
    """A day-long MPC record (tuning family mpc_siso_controls, seed 2, no change) with the PV lost
    every 250 rows: the step + ramp scan met an onset whose columns the mask leaves collinear
    with the level and raised "Singular matrix"; now it is scored by the minimum-norm solution
    and the record gets its answer, no process finding."""
    from mpmpp import families as fam
    from mpmpp.evaluate import nominal_model
    from mpmpp.simulate import simulate
    spec, _ = fam.family("mpc_siso_controls").draw(2, None, "none")
    model = nominal_model(spec)
    data = simulate(spec)
    data.loc[data.index[125::250], list(model.outputs)] = np.nan
    res = diagnose(model, data)
    assert not any(f.effect in PROCESS_EFFECTS for f in res.findings)


def test_the_noise_correction_is_one_per_disturbance_regime_over_the_data_segments():
    """Lost samples cut one disturbance regime into data segments: one AR correction is fitted
    over all of them (rows from SETTLE into each), as a plain least-squares AR beside the input
    basis on those rows gives it, and each segment whitens by it; with a cut (the noise split)
    the segments after it get their own."""
    from mpmpp.diagnose.whitening import AR_ORDER, SETTLE, _corrections
    rng = np.random.default_rng(3)
    n = 1200
    free = lfilter([1.0], [1.0, -1.1, 0.3], rng.standard_normal(n))
    inputs = rng.standard_normal((n, 2))
    pieces = [(0, 290), (291, 600), (601, 900), (901, 1200)]
    ar, sigma, root = _corrections(free, pieces, inputs, (0.0,))
    assert root == [0.0] * 4
    rows = np.concatenate([np.arange(a + SETTLE, b) for a, b in pieces])
    lagged = free[rows[:, None] - np.arange(1, AR_ORDER + 1)]
    ref = np.linalg.lstsq(np.column_stack([lagged, inputs[rows]]), free[rows], rcond=None)[0]
    for poly in ar:
        np.testing.assert_allclose(poly, np.r_[1.0, -ref[:AR_ORDER]], atol=1e-10)
    innovations = np.concatenate([lfilter(ar[0], [1.0], free[a:b])[SETTLE:] for a, b in pieces])
    assert sigma == [pytest.approx(np.sqrt(np.mean(innovations**2)), rel=1e-12)] * 4
    split, _, _ = _corrections(free, pieces, inputs, (0.0,), cuts=[601])
    assert np.array_equal(split[0], split[1]) and np.array_equal(split[2], split[3])
    assert not np.allclose(split[0], split[2])


@pytest.mark.parametrize("num", [[0.0], [0.1, -0.1]], ids=["zero", "washout"])
def test_a_channel_of_zero_gain_is_diagnosed(num):
    # a hand-written channel of gain 0 ("no effect") and a washout (zero DC gain, a transient):
    # the time-constant candidates keep the DC gain by scaling, which a zero gain cannot give
    # ("num has a non-finite coefficient" before); a zero channel is searched as one the model
    # lacks, and its update writes the channel
    data = loop.simulate(n=8000, seed=4, onset=4000, gain=2.0)
    noise = loop.model().noise("y")
    model = mpmpp.Model("zero channel", loop.TS, ["u"], ["y"], {"y": {"u": mpmpp.TransferFunction(num, [1.0, -0.9], 6)}},
                        {"y": noise})
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # no 0/0 on the way (check's reading divided by the gain)
        assert foptd_parameters(model.process("y", "u"), loop.TS) is None
        res = diagnose(model, data)
    assert all(np.isfinite(f.confidence) for f in res.findings)
    if num == [0.0]:
        (top,) = [f for f in res.findings if f.effect in PROCESS_EFFECTS][:1]
        assert (top.effect, top.input) == ("missing_coupling", "u")
        channel = update(model, data, top.id).model.process("y", "u")
        assert channel.dc_gain() > 0.5
