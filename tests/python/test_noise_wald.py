"""The noise channels' Wald test of the recommended presets (DetectorConfig::noise_test "wald"):
the window features are the residual regression's A(q) (noise_test "residual", the presets) or the
ARX step's a_1..a_na (noise_test "wald", what detector files written before "residual" existed
say), each with sigma^2 (Phi'Phi)^-1, checked against plain least-squares references; a noise change alarms the noise channel only; a process change
does not raise a noise alarm on its output (Detector::counts_for_indicator)."""
import json

import numpy as np
import pytest

import identification_reference as ref
import mpmpp
from residual_reference import reference_window
from mpmpp import _core
from mpmpp.detect import Detector, _arrays, detect, make_config
from mpmpp.evaluate import load_scenario, nominal_model
from mpmpp.simulate import simulate


def _paper(name, seed, hours=None):
    spec = load_scenario(name)
    spec["seed"] = seed
    if hours is not None:
        spec["duration_s"] = hours * 3600.0
        spec["events"] = [e for e in spec["events"] if e["time_s"] < spec["duration_s"]]
    return nominal_model(spec), simulate(spec)


def test_presets_use_the_wald_noise_test_and_the_paper_presets_do_not():
    assert make_config("siso").noise_test == "residual" and make_config("mimo").noise_test == "residual"
    assert make_config("paper_siso").noise_test == "svm" and make_config("paper_mimo").noise_test == "svm"
    with pytest.raises(ValueError, match="noise_test"):
        make_config({"preset": "siso", "noise_test": "bogus"})


def test_wald_noise_channels_beside_svm_process_channels():
    # The paper's preset (SVM process channels, no estimator covariances) with the Wald noise
    # test: only the noise channels carry covariances, and every window after the noise change
    # at 7 h scores negative. (Whether it alarms depends on the SVM's process windows, which
    # are often negative on this preset: the noise windows are then passed over.)
    model, data = _paper("paper_siso", 5)
    config = make_config({"preset": "paper_siso", "noise_test": "wald"})
    time_s, u, y = _arrays(model, data)
    features = _core.WindowFeatures(model, config)
    series = features.extract_series(time_s, u, y)
    widths = {c[0]: series.covariances[k].shape[1] for k, c in enumerate(features.channels)}
    assert widths == {"process": 0, "noise": config.arx_order_a ** 2}
    r = detect(model, data, None, config)
    k = [k for k, c in enumerate(r.channels) if c["kind"] == "noise"][0]
    end_h = (r.windows["end_s"].to_numpy() - float(data["time"].iloc[0])) / 3600
    assert (r.scores[end_h >= 8, k] < 0).all() and (r.scores[(end_h > 3) & (end_h <= 7), k] > 0).all()


def _noise_windows(model, data, config):
    time_s, u, y = _arrays(model, data)
    features = _core.WindowFeatures(model, config)
    series = features.extract_series(time_s, u, y)
    noise = [k for k, c in enumerate(features.channels) if c[0] == "noise"][0]
    n = config.window_samples(model.sample_time_s)
    for w in (0, len(series.windows) // 2):
        first = series.windows[w]["first"]
        yield y[first:first + n, 0], u[first:first + n], series.features[noise][w], series.covariances[noise][w]


def test_noise_features_are_the_arx_step_with_its_covariance():
    model, data = _paper("paper_siso", 4, hours=5)
    config = make_config({"preset": "siso", "noise_test": "wald"}, model)
    na = config.arx_order_a
    delay = model.process(model.outputs[0], model.inputs[0]).delay
    for yw, uw, feature, covariance in _noise_windows(model, data, config):
        yw, uw = yw - yw.mean(), uw - uw.mean(axis=0)  # the ARX-OE step's mean detrending
        theta, sigma2, regularised = ref.arx(yw, uw, na, [config.arx_order_b + 1], [delay], delta=1e-4)
        assert not regularised
        Phi, _ = ref.arx_regressors(yw, uw, na, [config.arx_order_b + 1], [delay])
        np.testing.assert_allclose(feature, theta[:na], rtol=1e-7, atol=1e-9)
        cov = (sigma2 * np.linalg.inv(Phi.T @ Phi))[:na, :na]
        np.testing.assert_allclose(covariance.reshape(na, na), cov, rtol=1e-6)


def test_preset_noise_features_are_the_residual_regressions_own_ar():
    model, data = _paper("paper_siso", 4, hours=5)
    config = make_config("siso", model)
    na = config.residual_ar_order or config.arx_order_a
    g = model.process(model.outputs[0], model.inputs[0])
    for yw, uw, feature, covariance in _noise_windows(model, data, config):
        settle = _core.residual_regression(model, 0, [0], config, yw, uw)[2]
        _, _, ar, ar_cov = reference_window(g, yw, uw[:, 0], na, config.laguerre_terms, settle,
                                          config.residual_steps, config.step_significance,
                                          config.outlier_sigmas)
        np.testing.assert_allclose(feature, ar, rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(covariance.reshape(na, na), ar_cov, rtol=1e-6,
                                   atol=1e-9 * np.abs(ar_cov).max())


def test_the_residual_noise_test_needs_the_residual_process_test():
    with pytest.raises(ValueError, match='noise_test "residual" needs process_test "residual"'):
        make_config({"preset": "siso", "process_test": "svm"})
    make_config({"preset": "siso", "process_test": "svm", "noise_test": "wald"}).validate()


def test_noise_change_alarms_the_noise_channel_with_the_paper_training_length():
    # Table 1's 3 h of training; the noise change of dry_weight at 7 h, the gain at 11 h.
    model, data = _paper("paper_siso", 211)
    r = detect(model, data, 3 * 3600, "siso")
    t0 = float(data["time"].iloc[0])
    starts = {c["kind"]: r.alarm_starts(k) - t0 for k, c in enumerate(r.channels)}
    assert starts["noise"].size and starts["noise"].min() >= 7 * 3600
    assert starts["process"].size and starts["process"].min() >= 11 * 3600


def test_a_process_change_raises_no_noise_alarm_on_its_output(tmp_path):
    # Paper MIMO: G11 (press_dry_weight <- stock_flow) doubles at 20.83 h. Windows straddling the
    # change score negative on H[press_dry_weight] (the ARX's A(q) absorbs what one B cannot fit
    # on both sides); they must not count while G11's own test is negative.
    model, data = _paper("paper_mimo", 3)
    result, detector = detect(model, data, config="mimo", return_detector=True)
    labels = [(c["kind"], c["output"], c.get("input")) for c in result.channels]
    h11 = labels.index(("noise", "press_dry_weight", None))
    g11 = labels.index(("process", "press_dry_weight", "stock_flow"))
    h22 = labels.index(("noise", "press_moisture", None))
    change = float(data["time"].iloc[0]) + 75000.0
    straddling = (result.windows["end_s"] > change) & (result.windows["start_s"] < change)
    assert np.nanmin(result.scores[straddling.to_numpy(), h11]) < 0  # the raw window test fires
    assert result.alarm_starts(g11).size and result.alarm_starts(g11).min() >= change
    assert result.alarm_starts(h11).size == 0
    assert result.alarm_starts(h22).size
    # A saved detector, batch and sample by sample (the plant path), gates the same way.
    path = tmp_path / "detector.json"
    detector.save(path)
    loaded = Detector.load(path)
    assert json.dumps(loaded.monitor(data).to_dict()["alarms"]) == json.dumps(result.to_dict()["alarms"])
    windows = mpmpp.StreamingDetector(loaded).push_block(
        data["time"].to_numpy(), data[list(model.inputs)].to_numpy(), data[list(model.outputs)].to_numpy())
    np.testing.assert_array_equal(np.array([w.indicator for w in windows])[:, h11], result.indicator[:, h11])


def test_noise_channels_take_their_own_level():
    # siso: process windows at 0.01 (pooled), the noise channel at 0.001. The noise channel's
    # p-value does not depend on the level, so its score, log10(p / level), moves by exactly
    # log10(0.01 / 0.001) = 1 when it is judged at the process level instead.
    model, data = _paper("paper_siso", 3, hours=9)
    trained = 6 * 3600.0  # the preset's training, set: a 9 h record is not fitted (no single windows)
    own = detect(model, data, trained, config="siso", return_detector=True)
    shared = detect(model, data, trained, config={"preset": "siso", "noise_significance": 0}, return_detector=True)
    levels = {c["kind"]: s.significance for c, s in zip(own[0].channels, own[1]._core.scorers)}
    assert levels == {"process": 0.01, "noise": 0.001}
    noise = [k for k, c in enumerate(own[0].channels) if c["kind"] == "noise"]
    monitored = ~own[0].windows["training"].to_numpy()
    np.testing.assert_allclose(own[0].scores[monitored][:, noise] - shared[0].scores[monitored][:, noise], 1.0,
                               atol=1e-9)
    with pytest.raises(ValueError, match="noise_significance"):
        make_config({"preset": "siso", "noise_significance": -0.1})
