"""compare: k-step prediction and residual tests against plain NumPy/SciPy references."""
import importlib
import json

import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter

import mpmpp
from mpmpp import _core
from mpmpp.compare import _failing_periods, compare
from mpmpp.diagnose.result import InsufficientData
from mpmpp.diagnose.whitening import estimated_noise_model, estimated_noise_note
from mpmpp.signals import extract

import pi_loop
from example_cases import NOISE_CHANGE, load_case

G_NUM, G_DEN, G_DELAY = [0.1], [1.0, -0.9], 4
H_NUM, H_DEN = [1.0, -0.3], [1.0, 0.5]


def _tf(num, den, delay=0):
    return mpmpp.TransferFunction(num, den, delay)


def _siso(n, seed, extra_gain=0.0, noise_scale_after=None):
    """Open-loop data y = G u + H e (+ an extra column w through 0.05/(1-0.8q^-1) q^-3)."""
    rng = np.random.default_rng(seed)
    u = np.repeat(rng.standard_normal(n // 10 + 1), 10)[:n]
    w = np.repeat(rng.standard_normal(n // 20 + 1), 20)[:n]
    e = 0.05 * rng.standard_normal(n)
    if noise_scale_after is not None:
        e[n // 2:] *= noise_scale_after
    y = lfilter(np.r_[np.zeros(G_DELAY), G_NUM], G_DEN, u) + lfilter(H_NUM, H_DEN, e)
    y += extra_gain * lfilter([0, 0, 0, 0.05], [1.0, -0.8], w)
    data = pd.DataFrame({"time": 5.0 * np.arange(n), "u": u + 100.0, "y": y + 50.0, "w": w})
    model = mpmpp.Model("t", 5.0, ["u"], ["y"],
                        process={"y": {"u": mpmpp.TransferFunction(G_NUM, G_DEN, G_DELAY)}},
                        noise={"y": mpmpp.TransferFunction(H_NUM, H_DEN)})
    return model, data, e


def _numpy_k_step_error(v, k):
    """Reference: innovations e = H^-1 v, then the k-step error sum_{i<k} h_i e(t-i)."""
    e = lfilter(H_DEN, H_NUM, v)
    h = lfilter(H_NUM, H_DEN, np.r_[1.0, np.zeros(k - 1)])
    return lfilter(h, [1.0], e)


@pytest.mark.parametrize("k", [1, 2, 7])
def test_k_step_prediction_matches_numpy_reference(k):
    rng = np.random.default_rng(1)
    u = rng.standard_normal((600, 1))
    y = rng.standard_normal(600)
    g, h = _tf(G_NUM, G_DEN, G_DELAY), _tf(H_NUM, H_DEN)
    v = y - lfilter(np.r_[np.zeros(G_DELAY), G_NUM], G_DEN, u[:, 0])
    yhat = _core.predict_output([g], h, y, u, k)
    np.testing.assert_allclose(y - yhat, _numpy_k_step_error(v, k), atol=1e-12)


def test_k_step_error_variance_is_the_analytic_one_for_the_true_model():
    model, data, e = _siso(40000, seed=2)
    u = data[["u"]].to_numpy() - 100.0
    y = data["y"].to_numpy() - 50.0
    h = lfilter(H_NUM, H_DEN, np.r_[1.0, np.zeros(5)])
    for k in (1, 3, 6):
        err = y - _core.predict_output([model.process("y", "u")], model.noise("y"), y, u, k)
        expected = 0.05**2 * np.sum(h[:k] ** 2)
        assert abs(np.var(err[100:]) / expected - 1.0) < 0.05


def test_cross_correlation_matches_numpy():
    rng = np.random.default_rng(3)
    x, y = rng.standard_normal(300), rng.standard_normal(300)
    r = _core.cross_correlation(x, y, 5)
    xc, yc = x - x.mean(), y - y.mean()
    full = np.correlate(xc, yc, mode="full") / np.sqrt(xc @ xc * (yc @ yc))  # index N-1 is lag 0
    np.testing.assert_allclose(r, full[299 - 5:299 + 6], atol=1e-12)


def test_true_model_passes_and_fit_matches_definition():
    model, data, _ = _siso(8000, seed=4)
    res = compare(model, data, horizon=5)
    oc = res.outputs[0]
    y = data["y"].to_numpy() - data["y"].mean()
    assert oc.fit_simulation == pytest.approx(
        100 * (1 - np.linalg.norm(y - oc.simulated) / np.linalg.norm(y - y.mean())), rel=1e-9)
    att = {a.column: a for a in oc.attribution}
    assert not att["u"].significant and not att["w"].significant
    assert len(oc.whiteness.positive_lag_violations) <= 2   # 25 lags at 99 %: ~0.25 expected
    assert not oc.failing
    json.dumps(res.to_dict())


def _flow_model(gain_factor: float) -> mpmpp.Model:
    """The FOPTD model a user writes for pi_loop's flow loop: no noise model."""
    loop = pi_loop.FLOW
    g = mpmpp.TransferFunction.from_foptd(loop.gain * gain_factor, loop.time_constant_s, loop.dead_time_s, 10.0)
    return mpmpp.Model("flow", 10.0, ["OP"], ["PV"], {"PV": {"OP": g}}, {})


def _model_error_flagged(oc) -> bool:
    return bool(oc.cross[0].positive_lag_violations) or oc.attribution[0].significant


def test_a_model_without_noise_model_is_judged_through_the_estimated_disturbance():
    """A PI flow loop (2 h at 10 s, setpoint steps, an AR(1) disturbance of pole 0.9) and its
    FOPTD model with no noise model. With H = 1 the one-step error is the coloured disturbance,
    which the controller's past moves predict: the right model was read as wrong on every seed
    (20 of 20, seeds 0-19, with either gain 2x or 0.5x off too). Through the disturbance model
    diagnose estimates, the right model passes (1 of 20 flagged) and the wrong gains are flagged
    (20 of 20 each); the error is A(q) (y - G u) with that A, as SciPy filters it."""
    flagged = {f: 0 for f in (1.0, 2.0, 0.5)}
    for seed in range(10):
        data = pi_loop.simulate(pi_loop.FLOW, seed, setpoint_steps=True)
        for f in flagged:
            res = compare(_flow_model(f), data)
            flagged[f] += _model_error_flagged(res.outputs[0])
    assert flagged[1.0] <= 2 and flagged[2.0] == flagged[0.5] == 10
    assert res.disturbance == [estimated_noise_note("PV")] and "AR(10)" in res.summary()

    sig = extract(_flow_model(0.5), data)
    a = estimated_noise_model(sig, 0, np.ones(len(data), bool)).den
    g = sig.rows[0][0]
    v = sig.y[:, 0] - lfilter(np.r_[np.zeros(g.delay), g.num], g.den, sig.u[:, 0])
    np.testing.assert_allclose(res.outputs[0].residual, lfilter(a, [1.0], v), atol=1e-9)


def test_a_disturbance_model_that_cannot_be_estimated_leaves_h_1_and_says_so(monkeypatch):
    def refuse(*_):
        raise InsufficientData("40 rows for an AR(10) fit")

    monkeypatch.setattr(importlib.import_module("mpmpp.diagnose.whitening"), "estimated_noise_model", refuse)
    data = pi_loop.simulate(pi_loop.FLOW, 0, setpoint_steps=True)
    res = compare(_flow_model(1.0), data)
    assert res.disturbance == ["PV: the model has no noise model, and none could be estimated (40 rows for an AR(10) "
                               "fit): the one-step error is the output error y - G u, coloured by the disturbance, "
                               "and its tests read it so"]
    sig = extract(_flow_model(1.0), data)
    g = sig.rows[0][0]
    v = sig.y[:, 0] - lfilter(np.r_[np.zeros(g.delay), g.num], g.den, sig.u[:, 0])
    np.testing.assert_allclose(res.outputs[0].residual, v, atol=1e-9)


def test_where_it_fails_is_where_the_gain_changed_and_nowhere_on_a_right_model():
    """12 h of the PI flow loop, the FOPTD model without a noise model: right throughout, no
    failing period (0 of 20 seeds); the process gain cut to 0.4x at 6 h, failing periods on 15
    of 20, each ending after the change (1 h windows)."""
    right, located = 0, 0
    for seed in range(10):
        data = pi_loop.simulate(pi_loop.FLOW, seed, rows=4320, setpoint_steps=True)
        right += bool(compare(_flow_model(1.0), data).outputs[0].failing)
        changed = pi_loop.simulate(pi_loop.FLOW, seed, rows=4320, setpoint_steps=True, gain_change=(2160, 0.4))
        periods = compare(_flow_model(1.0), changed).outputs[0].failing
        located += bool(periods) and all(p.end_s > 6 * 3600 for p in periods)
    assert right <= 1 and located >= 6


def test_a_failing_period_in_a_record_of_white_errors_is_rare():
    """A day of white one-step errors at 10 s (1 h windows every 15 min, 93 of them): the chance
    of any failing period is the record's FAILING_LEVEL of 1 % plus the reference's own error
    (8 of 400 records). Three spreads per window, without the record's multiplicity, gave 32."""
    n, window, step = 8640, 360, 90
    first = np.arange(0, n - window + 1, step)
    with_period = 0
    for seed in range(400):
        e = np.random.default_rng(seed).standard_normal(n)
        rms = np.array([np.sqrt(np.mean(e[f:f + window] ** 2)) for f in first])
        with_period += bool(_failing_periods(first * 10.0, rms, window, step, 10.0))
    assert with_period <= 16   # 4 %: binomial(400, 0.02) exceeds it with probability ~0.1 %


def test_unmodeled_column_and_noise_change_are_located():
    model, data, _ = _siso(8000, seed=5, extra_gain=1.0)
    oc = compare(model, data).outputs[0]
    att = {a.column: a for a in oc.attribution}
    assert att["w"].significant and not att["u"].significant
    w = next(c for c in oc.cross if c.column == "w")
    assert 4 in w.positive_lag_violations  # delay 3 + one sample of the numerator lag

    model, data, _ = _siso(8000, seed=6, noise_scale_after=2.0)
    oc = compare(model, data, window_s=1800).outputs[0]
    assert oc.failing and abs(oc.failing[0].start_s - 5.0 * 4000) <= 1800


def test_missing_values_split_segments_not_interpolated():
    model, data, _ = _siso(3000, seed=7)
    data.loc[1500:1504, "y"] = np.nan
    res = compare(model, data)
    assert res.skipped_rows == 5
    assert np.isnan(res.outputs[0].residual[1500:1505]).all()
    assert np.isfinite(res.outputs[0].residual[1505:]).all()


def test_bad_arguments_name_the_field():
    model, data, _ = _siso(1000, seed=8)
    with pytest.raises(ValueError, match="horizon"):
        compare(model, data, horizon=0)
    with pytest.raises(ValueError, match="'y'"):
        compare(model, data.drop(columns=["y"]))


def test_noise_change_is_where_it_fails(tmp_path):
    model, data, truth = load_case(NOISE_CHANGE)
    res = compare(model, data)
    by = {oc.output: oc for oc in res.outputs}
    changed = by[truth["output"]]
    assert changed.failing and abs(changed.failing[0].start_s - truth["onset_s"]) <= 3600
    assert not any(oc.failing for name, oc in by.items() if name != truth["output"])
    paths = res.plot(tmp_path)
    assert len(paths) == 6 and all(p.stat().st_size > 1000 for p in paths)
