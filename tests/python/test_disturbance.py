"""The disturbance model detect works with (mpmpp.disturbance): the estimate for an output
without a noise model against a plain NumPy least-squares fit and BIC, the order of a given
H against its analytic inverse, the notes detect writes, and detection with and without the
noise model in the file on the paper's SISO loop (seeds never used for tuning)."""
import json
import math

import numpy as np
import pandas as pd
from scipy.signal import lfilter

import mpmpp
from mpmpp import _core, scenarios
from mpmpp.detect import Detector, _arrays, _cover_disturbance, detect, make_config
from mpmpp.disturbance import WHITENING_FLOOR, disturbance_orders, inverse_order
from mpmpp.model_identification import MA_ROOTS
from mpmpp.evaluate import nominal_model
from mpmpp.simulate import simulate

TS = 5.0
G_NUM, G_DEN, G_DELAY = [0.5], [1.0, -0.8], 3
AR_TRUE = np.array([1.0, -1.2, 0.5])   # v_t = 1.2 v_{t-1} - 0.5 v_{t-2} + e_t


def model(noise=None):
    doc = {"name": "t", "sample_time_s": TS, "inputs": ["u"], "outputs": ["y"],
           "process": {"y": {"u": {"num": G_NUM, "den": G_DEN, "delay": G_DELAY}}}}
    if noise:
        doc["noise"] = {"y": noise}
    return mpmpp.Model.from_json(json.dumps(doc), "test")


def loop_data(n=6000, seed=1, ar=AR_TRUE, ma=(1.0,)):
    rng = np.random.default_rng(seed)
    u = 3.0 + np.repeat(rng.normal(0, 1, n // 40 + 1), 40)[:n]
    v = lfilter(list(ma), ar, rng.normal(0, 0.1, n))
    g = lfilter(np.r_[np.zeros(G_DELAY), G_NUM], G_DEN, u - u.mean())
    return pd.DataFrame({"time": TS * np.arange(n), "u": u, "y": 10.0 + g + v})


def numpy_bic_ar(v, begin, end, cap):
    """Plain least squares per order on rows [begin, end), BIC = N log s2 + p log N."""
    n = end - begin
    best = (n * math.log(np.mean(v[begin:end] ** 2)), 0, np.array([1.0]))
    for p in range(1, cap + 1):
        lags = np.column_stack([v[begin - k:end - k] for k in range(1, p + 1)])
        a, *_ = np.linalg.lstsq(lags, v[begin:end], rcond=None)
        s2 = np.mean((v[begin:end] - lags @ a) ** 2)
        bic = n * math.log(s2) + p * math.log(n)
        if bic < best[0]:
            best = (bic, p, np.r_[1.0, -a])
    return best[1], best[2]


def numpy_bic_ar_rows(v, rows, cap):
    """numpy_bic_ar on the given rows only (their lags all present)."""
    n = len(rows)
    best = (n * math.log(np.mean(v[rows] ** 2)), 0, np.array([1.0]))
    for p in range(1, cap + 1):
        lags = np.column_stack([v[rows - k] for k in range(1, p + 1)])
        a, *_ = np.linalg.lstsq(lags, v[rows], rcond=None)
        bic = n * math.log(np.mean((v[rows] - lags @ a) ** 2)) + p * math.log(n)
        if bic < best[0]:
            best = (bic, p, np.r_[1.0, -a])
    return best[1], best[2]


def reference_output_error(u, y, rows):
    """y - G u on the first ``rows`` rows' deviations, G filtering from rest at the first row."""
    du, dy = u[:rows, 0] - u[:rows, 0].mean(), y[:rows, 0] - y[:rows, 0].mean()
    return dy - lfilter(np.r_[np.zeros(G_DELAY), G_NUM], G_DEN, du)


def test_estimate_matches_numpy_least_squares_and_bic():
    data, train_end_s, window = loop_data(), 5000 * TS, 1440
    t, u, y = _arrays(model(), data)
    (d,) = disturbance_orders(model(), t, u, y, train_end_s, window)
    # Reference: the output error of the nominal model from rest at the first row, on the
    # training rows' deviations; rows from the settling time (G's impulse response below 1 %
    # of its peak) plus the largest order.
    rows = 5000
    v = reference_output_error(u, y, rows)
    impulse = np.abs(lfilter(np.r_[np.zeros(G_DELAY), G_NUM], G_DEN, np.r_[1.0, np.zeros(rows - 1)]))
    settle = np.flatnonzero(impulse >= 0.01 * impulse.max())[-1] + 1
    cap = min(30, window // 24)
    p, poly = numpy_bic_ar(v, settle + cap, rows, cap)
    assert d.estimated and d.rows == rows - settle - cap
    assert d.order == p
    np.testing.assert_allclose(d.polynomial, poly, rtol=1e-9, atol=1e-12)
    # and the truth: AR(2), coefficients within 4 standard errors (~0.013 on ~4900 rows)
    assert p == 2
    np.testing.assert_allclose(poly, AR_TRUE, atol=0.06)


def test_residual_variances_of_every_order_match_numpy_least_squares():
    """_core.ar_residual_variances (one Gram matrix for every order, bic_ar's search) against a
    plain least-squares fit per order on the same rows, with a lost sample among them."""
    v = lfilter([1.0, -0.8], AR_TRUE, np.random.default_rng(4).normal(0, 1, 3000))
    v[1700] = np.nan
    cap, begin, end = 12, 40, 3000
    s2 = np.asarray(_core.ar_residual_variances(v, cap, begin, end), dtype=float).ravel()
    t = np.arange(begin, end)
    rows = t[[np.all(np.isfinite(v[k - cap:k + 1])) for k in t]]
    assert len(rows) == end - begin - (cap + 1)
    reference = [np.mean(v[rows] ** 2)]
    for p in range(1, cap + 1):
        lags = np.column_stack([v[rows - k] for k in range(1, p + 1)])
        a, *_ = np.linalg.lstsq(lags, v[rows], rcond=None)
        reference.append(np.mean((v[rows] - lags @ a) ** 2))
    np.testing.assert_allclose(s2, reference, rtol=1e-9)


def test_estimate_uses_every_complete_stretch_of_the_training():
    """A row lost every 500 (u and y missing, as a timestamp the historian missed): the estimate
    is fitted on every stretch, each filtered from rest at its first row and its first rows (G's
    settling plus the largest order) left out, as a plain NumPy least-squares fit on those rows
    gives it (no step or ramp is found in these data); before, the longest stretch alone (499
    rows) left too few rows to estimate."""
    data, train_end_s, window = loop_data(), 5000 * TS, 1440
    lost = np.arange(250, 6000, 500)
    data.loc[lost, ["u", "y"]] = np.nan
    t, u, y = _arrays(model(), data)
    (d,) = disturbance_orders(model(), t, u, y, train_end_s, window)
    impulse = np.abs(lfilter(np.r_[np.zeros(G_DELAY), G_NUM], G_DEN, np.r_[1.0, np.zeros(499)]))
    settle = np.flatnonzero(impulse >= 0.01 * impulse.max())[-1] + 1
    cap = min(30, window // 24)
    train = np.arange(5000)
    ok = np.isin(train, lost, invert=True)
    u0, y0 = u[:5000][ok, 0].mean(), y[:5000][ok, 0].mean()
    v = np.full(5000, np.nan)
    fitted = []
    for a, b in zip(np.r_[0, lost[lost < 5000] + 1], np.r_[lost[lost < 5000], 5000]):
        e = (y[a:b, 0] - y0) - lfilter(np.r_[np.zeros(G_DELAY), G_NUM], G_DEN, u[a:b, 0] - u0)
        v[a + settle:b] = e[settle:]
        fitted += list(range(a + settle + cap, b))
    p, poly = numpy_bic_ar_rows(v, np.array(fitted), cap)
    assert d.estimated and d.rows == len(fitted) > 4000
    assert d.order == p == 2
    np.testing.assert_allclose(d.polynomial, poly, rtol=1e-9, atol=1e-12)


def test_order_of_a_given_noise_model_is_its_inverse_impulse_length():
    # 1/H = 1 - 0.5 q^-1: one tap after the first
    assert inverse_order(model({"num": [1.0], "den": [1.0, -0.5]}).noise("y"), 30) == 1
    # 1/H = 1/(1 + 0.5 q^-1): taps (-0.5)^k, the last >= 0.01 is k = 6
    assert inverse_order(model({"num": [1.0, 0.5], "den": [1.0]}).noise("y"), 30) == 6
    # 1/(1 - 0.95 q^-1): 0.95^k >= 0.01 up to k = 89, capped
    assert inverse_order(model({"num": [1.0, -0.95], "den": [1.0]}).noise("y"), 30) == 30


def test_detect_says_when_it_estimated_the_disturbance_model(tmp_path):
    data = loop_data(n=4000)
    plain = detect(model(), data, 3 * 3600.0, "paper_siso")
    assert len(plain.notes) == 1 and "no noise model" in plain.notes[0] and "AR(2)" in plain.notes[0]
    assert plain.to_dict()["notes"] == plain.notes
    assert "note: y: the model has no noise model" in plain.alarm_table()
    path = tmp_path / "detect.json"
    plain.save_json(path)
    assert json.loads(path.read_text())["notes"] == plain.notes
    given = detect(model({"num": [1.0], "den": [1.0, -1.2, 0.5]}), data, 3 * 3600.0, "paper_siso")
    assert given.notes == [] and given.to_dict()["notes"] == []


AR_FOURTH = np.poly([0.9, -0.8, 0.6 + 0.5j, 0.6 - 0.5j]).real


def test_the_residual_test_whitens_by_the_training_error_order_at_least_the_floor(tmp_path):
    """Every output's whitening order is the BIC order of its training output error (a noise
    model in the file does not set it), at least WHITENING_FLOOR; explicit orders and the SVM
    presets are left alone; the orders travel in the detector file, whose version 10 loads
    without them."""
    cases = {"AR(2)": (AR_TRUE, WHITENING_FLOOR), "AR(4)": (AR_FOURTH, 4)}
    for label, (poly, expected) in cases.items():
        data = loop_data(ar=poly)
        t, u, y = _arrays(model(), data)
        claimed = model({"num": [1.0], "den": [1.0, -0.5]})   # 1/H = 1 - 0.5 q^-1: order 1
        (d,) = disturbance_orders(claimed, t, u, y, 5000 * TS, 1440)
        rows = 5000
        p, _ = numpy_bic_ar(reference_output_error(u, y, rows), rows - d.rows, rows, min(30, 1440 // 24))
        assert (d.order, d.whitening) == (1, p) and p == len(poly) - 1, label
        config, _ = _cover_disturbance(make_config("siso"), claimed, t, u, y, 5000 * TS)
        assert config.residual_ar_orders == [expected], label
    for given in ({"preset": "siso", "residual_ar_order": 5}, "paper_siso"):
        config, _ = _cover_disturbance(make_config(given), claimed, t, u, y, 5000 * TS)
        assert config.residual_ar_orders == []
    _, notes = _cover_disturbance(make_config("siso"), model(), t, u, y, 5000 * TS)
    assert notes[0].endswith("A the BIC-chosen AR(4) of y - G u less its steps and ramps; the residual test whitens "
                             "each window by an AR(4)")
    _, det = detect(model(), data, 3 * 3600.0, "siso", return_detector=True)
    assert det._core.config.residual_ar_orders == [4]
    path = tmp_path / "d.json"
    det.save(path)
    assert json.loads(path.read_text())["config"]["residual_ar_orders"] == [4]
    # A version 10 file whitened every output by n_a (9 here): without the key it still does.
    _, det = detect(model(), data, 3 * 3600.0, {"preset": "siso", "residual_ar_orders": [9]}, return_detector=True)
    det.save(path)
    doc = json.loads(path.read_text())
    assert doc["version"] == 12
    doc["version"] = 10
    del doc["config"]["residual_ar_orders"]
    old = _core.Detector.from_json(json.dumps(doc), "v10.json")
    assert old.config.residual_ar_orders == [] and old.config.arx_order_a == 9
    np.testing.assert_array_equal(Detector(old).monitor(data).scores, det.monitor(data).scores)


def test_a_wandering_disturbance_gets_a_moving_average_root_in_the_whitening(tmp_path):
    """A disturbance (1 - 0.8 q^-1) / (1 - 0.995 q^-1) e (a wandering operating point): the
    whitening's root and order are the BIC choice over MA_ROOTS of the training output error less
    its mean through 1 / (1 - c q^-1) (a NumPy reference: plain least squares per order, one
    more coefficient for c > 0), 0.8 here with a short AR where c = 0 alone needs a long one; an AR(2)
    disturbance keeps c = 0. The root travels in the config and the detector file (version 12);
    a version 11 file, without the key, loads with none."""
    for ar, ma, root in (([1.0, -0.995], [1.0, -0.8], 0.8), (AR_TRUE, [1.0], 0.0)):
        data = loop_data(ar=np.array(ar), ma=ma)
        t, u, y = _arrays(model(), data)
        (d,) = disturbance_orders(model(), t, u, y, 5000 * TS, 1440)
        rows, cap = 5000, min(30, 1440 // 24)
        v = reference_output_error(u, y, rows)
        begin = rows - d.rows
        scores = {}
        w = v[begin - cap:rows] - v[begin:rows].mean()   # known from begin - cap on (the process settled)
        for c in MA_ROOTS:
            vc = np.r_[np.zeros(begin - cap), lfilter([1.0], [1.0, -c], w)]
            p, poly = numpy_bic_ar(vc, begin, rows, cap)
            n = rows - begin
            bic = n * math.log(np.mean(np.convolve(vc[begin - p:rows], poly, mode="valid") ** 2)) + p * math.log(n)
            scores[c] = (bic + (math.log(n) if c else 0.0), p)
        best = min(scores, key=lambda c: scores[c][0])
        assert (d.whitening_root, d.whitening) == (best, scores[best][1]) and best == root
        config, notes = _cover_disturbance(make_config("siso"), model(), t, u, y, 5000 * TS)
        assert config.residual_ma_roots == ([root] if root else [])
        if root:
            assert scores[0.0][1] >= 3 * max(scores[root][1], 1)
            assert notes[0].endswith(f"AR({config.residual_ar_orders[0]}) after 1/(1 - 0.8 q^-1) (a wandering "
                                     "disturbance)")
    data = loop_data(ar=np.array([1.0, -0.995]), ma=[1.0, -0.8])
    _, det = detect(model(), data, 3 * 3600.0, "siso", return_detector=True)
    t, u, y = _arrays(model(), data)
    roots = _cover_disturbance(make_config("siso"), model(), t, u, y, 3 * 3600.0)[0].residual_ma_roots
    assert det._core.config.residual_ma_roots == roots and roots[0] >= 0.7   # 0.7 on these 3 h
    path = tmp_path / "d.json"
    det.save(path)
    doc = json.loads(path.read_text())
    assert doc["version"] == 12 and doc["config"]["residual_ma_roots"] == roots
    doc["version"] = 11
    del doc["config"]["residual_ma_roots"]
    assert _core.Detector.from_json(json.dumps(doc), "v11.json").config.residual_ma_roots == []


def test_step_and_ramp_disturbances_do_not_raise_the_whitening_order():
    """An unmeasured load step and a ramp that starts and stops during training: fitted as they
    stand, they ask BIC for many more coefficients than the AR(2) disturbance has; the estimate
    takes them out first (diagnose's step finder) and finds the AR(2) (15 as they stand)."""
    data = loop_data()
    n = len(data)
    t = np.arange(n)
    load = 1.5 * (t >= 1500) + np.clip(t - 3000, 0, 400) / 400 * -1.0   # a step, then a 400-sample ramp
    data["y"] += load
    tt, u, y = _arrays(model(), data)
    (d,) = disturbance_orders(model(), tt, u, y, 5000 * TS, 1440)
    rows = 5000
    as_they_stand, _ = numpy_bic_ar(reference_output_error(u, y, rows), rows - d.rows, rows, min(30, 1440 // 24))
    assert d.whitening == 2 and d.order == 2
    assert as_they_stand > 2


def test_too_few_training_rows_keep_the_config_order_and_say_so():
    data = loop_data(n=4000)
    t, u, y = _arrays(model(), data)
    (d,) = disturbance_orders(model(), t, u, y, 100 * TS, 1440)
    assert d.estimated and d.polynomial is None and d.order == 0
    config, notes = _cover_disturbance(make_config("paper_siso"), model(), t, u, y, 100 * TS)
    assert config.arx_order_a == 9
    assert notes == ["y: the model has no noise model, and the training period leaves 46 complete rows after "
                     "the process settles, too few to estimate one; the ARX order n_a = 9 of the config stands"]


def test_paper_presets_keep_their_arx_orders():
    # Tables 1 and 3's n_a already cover the paper's noise models: the rule changes nothing there.
    for sc, n_a in ((scenarios.paper_siso(), 9), (scenarios.paper_mimo(), 18)):
        m = nominal_model(sc)
        assert max(inverse_order(m.noise(o), 30) for o in m.outputs) < n_a


def paper_siso_outcomes(noise_in_file: bool, seeds, config):
    """(detected, false MPM alarm) per seed: the gain doubling at 11 h found by an MPM alarm at
    or after it; an MPM alarm before it (the 7 h noise change included) is false."""
    sc = scenarios.paper_siso()
    m = nominal_model(sc if noise_in_file else {k: v for k, v in sc.items() if k != "noise"})
    out = []
    for seed in seeds:
        data = simulate(sc, seed=seed)
        r = detect(m, data, 6 * 3600.0, config)
        starts = r.alarm_starts(0) - float(data["time"].iloc[0])
        out.append((bool((starts >= 11 * 3600).any()), bool((starts < 11 * 3600).any())))
        assert bool(r.notes) == (not noise_in_file)
    return np.array(out)


def test_no_noise_model_detects_like_the_noise_model_on_the_paper_siso_loop():
    # n_a = 2 is below both disturbance orders (the file's H: 4; the BIC estimate: 3-4), so the
    # rule sets n_a in both runs: this compares the estimated disturbance model with the true one.
    seeds, config = range(200, 210), {"preset": "siso", "arx_order_a": 2}
    with_h, without_h = paper_siso_outcomes(True, seeds, config), paper_siso_outcomes(False, seeds, config)
    n = len(seeds)
    # Binomial margin on the difference of the two detection counts: 2 sd of the difference of
    # two independent binomials at the pooled rate p (sd = sqrt(2 n p (1 - p))), at least 1.
    p = (with_h[:, 0].sum() + without_h[:, 0].sum()) / (2 * n)
    margin = max(1, math.ceil(2 * math.sqrt(2 * n * p * (1 - p))))
    assert abs(int(with_h[:, 0].sum()) - int(without_h[:, 0].sum())) <= margin
    # Both detect the doubling in most runs: at a true rate of 0.9, P(X <= 6 of 10) = 1.3 %.
    assert with_h[:, 0].sum() >= 7 and without_h[:, 0].sum() >= 7
    # and neither raises a false MPM alarm in more than 2 of 10 (P(X >= 3) = 1.2 % at a 5 % rate).
    assert with_h[:, 1].sum() <= 2 and without_h[:, 1].sum() <= 2


def test_cli_detect_prints_the_notes(tmp_path, capsys):
    from mpmpp import cli

    (tmp_path / "m.json").write_text(model().to_json())
    mpmpp.save_data(tmp_path / "d.csv", loop_data(n=4000))
    args = ["detect", str(tmp_path / "m.json"), str(tmp_path / "d.csv"), "--train-end", "10800", "--config", "paper_siso"]
    assert cli.main(args + ["--json"]) == 0
    assert "no noise model" in json.loads(capsys.readouterr().out)["notes"][0]
    assert cli.main(args) == 0
    assert "note: y: the model has no noise model" in capsys.readouterr().out
