"""Resampling with the estimator's own covariance (DetectorConfig.resampling = "estimator"):
the window covariances are ARX-OE's two-step ones, the training mean's covariance is the
windows' scaled by mean_variance_ratio, the training draws have covariance alpha^2 max(S, C_ref)
(direction by direction), each monitored deviation is carried into the training precision
(x <- mean + C_ref^1/2 (C + C_mean)^-1/2 (x - mean), checked against analytic cases), noise
channels use noise_alpha, and a trained detector scores identically after save/load and in
streaming."""
import copy

import numpy as np
import pytest
import scipy.linalg

import mpmpp
from mpmpp import _core, scenarios
from mpmpp.detect import Detector, make_config
from mpmpp.evaluate import nominal_model
from mpmpp.identify import arx_oe_model, channel_inputs

# resampling "estimator", alpha 1.25, noise_alpha 5, outlier fraction 0.05; the SVM on the
# process channels and the SVM on the noise channels (the preset judges both by Wald tests)
ESTIMATOR = {"preset": "mimo", "process_test": "svm", "noise_test": "svm"}


def estimator_config(**changes):
    c = make_config(ESTIMATOR)
    for k, v in changes.items():
        setattr(c, k, v)
    return c


def windows_and_covariances(n=73, seed=0):
    """Two anti-correlated FIR coefficients per window (as G11 of the paper MIMO example) and
    every window's OE covariance, the same C_ref for all."""
    rng = np.random.default_rng(seed)
    C_ref = np.array([[1.2e-4, -1.0e-4], [-1.0e-4, 1.0e-4]])
    X = np.array([0.06, 0.02]) + rng.standard_normal((n, 2)) @ np.linalg.cholesky(C_ref).T
    return X, np.tile(C_ref.reshape(1, 4), (n, 1)), C_ref


def without_reference(s):
    """The same scorer with no window-covariance mapping."""
    plain = _core.ChannelScorer()
    for name in ("feature_mean", "feature_scale", "feature_decorrelation", "support_vectors", "dual_coef",
                 "offset", "kernel_scale", "nu", "n_train"):
        setattr(plain, name, copy.deepcopy(getattr(s, name)))
    return plain


def symmetric_root(M, power):
    w, V = np.linalg.eigh(M)
    return (V * w ** power) @ V.T


@pytest.fixture(scope="module")
def scorer():
    X, covs, C_ref = windows_and_covariances()
    c = estimator_config(outlier_fraction=0.05)
    return _core.train_channel_scorer(X, c, seed=1, covariances=covs), X, C_ref


def test_reference_covariance_is_the_mean_window_covariance(scorer):
    s, _, C_ref = scorer
    np.testing.assert_allclose(s.reference_covariance, C_ref, rtol=1e-14)
    assert s.feature_decorrelation.shape == (2, 2)  # the draws are correlated: whitened
    assert s.mean_covariance.shape == (2, 2) and not s.mean_covariance.any()  # mean_ratio 0: exact mean


def test_mean_variance_ratio_analytic_cases():
    W = 100
    assert _core.mean_variance_ratio([0, 100, 200, 300], W) == pytest.approx(1 / 4)  # disjoint: 1/n
    assert _core.mean_variance_ratio([0, 0, 0], W) == pytest.approx(1.0)              # one window thrice
    # Two windows overlapping by half: var((A + B)/2 + (B + C)/2) / 4 with A, B, C halves = 3/4.
    assert _core.mean_variance_ratio([0, 50], W) == pytest.approx(0.75)
    # The paper MIMO training: 73 windows of 2 h every 5 min in 8 h.
    assert _core.mean_variance_ratio(np.arange(73) * 60, 1440) == pytest.approx(0.2928, abs=1e-4)
    with pytest.raises(ValueError, match="mean_variance_ratio"):
        _core.mean_variance_ratio([], W)


def test_mean_covariance_widens_the_frame_and_every_window():
    X, covs, C_ref = windows_and_covariances(seed=6)
    s = _core.train_channel_scorer(X, estimator_config(), seed=1, covariances=covs, mean_ratio=0.25)
    np.testing.assert_allclose(s.mean_covariance, 0.25 * C_ref, rtol=1e-14)
    np.testing.assert_allclose(s.reference_covariance, 1.25 * C_ref, rtol=1e-14)
    plain = without_reference(s)
    mean = np.asarray(s.feature_mean)
    for x in mean + 0.03 * np.random.default_rng(3).standard_normal((10, 2)):
        # A window as precise as the training ones: no mapping (C + C_mean = C_ref + C_mean).
        assert s.score_rows(x[None, :], C_ref.reshape(1, 4))[0] == pytest.approx(plain.score_rows(x[None, :])[0], abs=1e-12)
        C = np.array([[3e-4, 5e-5], [5e-5, 2e-5]])
        mapped = mean + symmetric_root(1.25 * C_ref, 0.5) @ symmetric_root(C + 0.25 * C_ref, -0.5) @ (x - mean)
        assert s.score_rows(x[None, :], C.reshape(1, 4))[0] == pytest.approx(plain.score_rows(mapped[None, :])[0], abs=1e-12)


def test_draws_have_covariance_alpha_squared_directional_max():
    X, covs, C_ref = windows_and_covariances(seed=4)
    X[:, 1] += 0.02 * np.random.default_rng(9).standard_normal(len(X))  # one direction looser than C_ref says
    S = np.cov(X, rowvar=False)
    # Reference by the generalised eigenproblem S v = l C_ref v (SciPy), V' C_ref V = I:
    # the spread is V^-T diag(max(l, 1)) V^-1.
    lam, V = scipy.linalg.eigh(S, C_ref)
    Vinv = np.linalg.inv(V)
    expected_spread = Vinv.T @ np.diag(np.maximum(lam, 1.0)) @ Vinv
    assert lam.min() < 1 < lam.max()  # both branches of the max are exercised
    spread = _core.directional_max(C_ref, S)
    np.testing.assert_allclose(spread, expected_spread, rtol=1e-10)
    for lower in (C_ref, S):  # at least as wide as either estimate
        assert np.linalg.eigvalsh(spread - lower).min() > -1e-12 * np.abs(spread).max()
    c = estimator_config(resampled_models=200_000)
    Z, correlated = _core.draw_training_models(X, c, 7, C_ref, noise=False)
    assert correlated
    np.testing.assert_allclose(np.cov(Z, rowvar=False), c.alpha ** 2 * expected_spread, rtol=0.02,
                               atol=0.02 * c.alpha ** 2 * np.abs(expected_spread).max())
    np.testing.assert_allclose(Z.mean(0), X.mean(0), atol=4 * c.alpha * np.sqrt(np.diag(expected_spread) / 200_000).max())


def test_noise_channels_use_noise_alpha_and_independent_draws():
    X, _, _ = windows_and_covariances(seed=5)
    c = estimator_config(resampled_models=100_000)
    Z, correlated = _core.draw_training_models(X, c, 3, noise=True)
    assert not correlated
    np.testing.assert_allclose(Z.std(0), c.noise_alpha * X.std(0, ddof=1), rtol=0.02)
    c.noise_alpha = 0  # 0: the process channels' alpha
    Z, _ = _core.draw_training_models(X, c, 3, noise=True)
    np.testing.assert_allclose(Z.std(0), c.alpha * X.std(0, ddof=1), rtol=0.02)


def test_window_precision_mapping_against_analytic_cases(scorer):
    s, X, C_ref = scorer
    plain = without_reference(s)
    mean = np.asarray(s.feature_mean)
    rng = np.random.default_rng(2)
    points = mean + 0.03 * rng.standard_normal((20, 2))
    score = lambda x, C: s.score_rows(x[None, :], C.reshape(1, 4))[0]  # noqa: E731
    for x in points:
        # A window as precise as training: no mapping.
        assert score(x, C_ref) == pytest.approx(plain.score_rows(x[None, :])[0], abs=1e-12)
        # Twice as precise in every direction (C = C_ref / 4): the deviation counts double.
        assert score(x, C_ref / 4) == pytest.approx(plain.score_rows((mean + 2 * (x - mean))[None, :])[0], abs=1e-12)
        # A general window covariance: the NumPy form of the mapping.
        C = np.array([[3e-4, 5e-5], [5e-5, 2e-5]])
        mapped = mean + symmetric_root(C_ref, 0.5) @ symmetric_root(C, -0.5) @ (x - mean)
        assert score(x, C) == pytest.approx(plain.score_rows(mapped[None, :])[0], abs=1e-12)


def test_a_noisier_window_is_not_taken_for_a_process_change(scorer):
    s, X, C_ref = scorer
    mean = np.asarray(s.feature_mean)
    # 8 standard deviations of a training window's estimate away (2-3 of the widened cloud).
    shift = mean + symmetric_root(C_ref, 0.5) @ np.array([8.0, 0.0])
    C_noisy = 16 * C_ref  # a noise change: the window's estimate is 4x looser, 2 of its sds away
    assert s.score_rows(shift[None, :], C_ref.reshape(1, 4))[0] < 0  # at training precision: a change
    assert s.score_rows(shift[None, :], C_noisy.reshape(1, 4))[0] > 0  # within the window's own spread


def test_bad_window_covariances(scorer):
    s, X, C_ref = scorer
    with pytest.raises(ValueError, match="window covariances"):
        s.score_rows(X[:3])  # the covariances are required
    with pytest.raises(ValueError, match="window covariances"):
        s.score_rows(X[:3], np.ones((3, 3)))
    not_pd = np.array([[1e-4, 2e-4], [2e-4, 1e-4]]).reshape(1, 4)
    assert np.isnan(s.score_rows(X[:1], not_pd)[0])  # no usable evidence, like a skipped window
    assert np.isnan(s.score_rows(X[:1], np.full((1, 4), np.nan))[0])


def test_config_needs_the_fir_structure_and_a_valid_noise_alpha():
    with pytest.raises(ValueError, match="resampling 'estimator' needs oe_structure 'fir'"):
        make_config({**ESTIMATOR, "oe_structure": "foptd"})
    with pytest.raises(ValueError, match="noise_alpha"):
        make_config({**ESTIMATOR, "noise_alpha": -1})
    c = make_config(ESTIMATOR)
    back = mpmpp.DetectorConfig.from_json(c.to_json())
    assert (back.resampling, back.noise_alpha, back.alpha, back.outlier_fraction) == ("estimator", 5.0, 1.25, 0.05)


@pytest.fixture(scope="module")
def short_mimo():
    """The paper MIMO loop, 11 h, G31 doubled at 8 h (no noise change): 2 h windows, 8 h training."""
    sc = scenarios.paper_mimo()
    sc["duration_s"] = 11 * 3600.0
    sc["events"] = [{"time_s": 8 * 3600.0, "type": "gain", "output": "reel_moisture", "input": "stock_flow",
                     "factor": 2.0}]
    model = nominal_model(sc)
    return model, mpmpp.simulate(sc, seed=3)


def test_window_covariances_are_the_two_step_covariance_blocks(short_mimo):
    model, data = short_mimo
    config = make_config(ESTIMATOR, model)
    time_s = data["time"].to_numpy()
    u, y = data[list(model.inputs)].to_numpy(), data[list(model.outputs)].to_numpy()
    series = _core.WindowFeatures(model, config).extract_series(time_s, u, y)
    channels = _core.WindowFeatures(model, config).channels
    W, step = config.window_samples(model.sample_time_s), config.step_samples(model.sample_time_s)
    for i, output in enumerate(model.outputs):
        ks = [k for k, (kind, o, _) in enumerate(channels) if kind == "process" and o == i]
        assert len(ks) == len(channel_inputs(model, output))
        estimates = arx_oe_model(model, data, output, na=config.arx_order_a, nb=config.arx_order_b + 1,
                                 structure="fir", window=W, step=step, two_step_covariance=True)
        assert len(estimates) == len(series.windows)
        for w in (0, len(estimates) // 2, len(estimates) - 1):
            C = np.asarray(estimates[w].result.two_step_covariance)
            offset = 0
            for k in ks:
                d = series.features[k].shape[1]
                np.testing.assert_allclose(series.covariances[k][w].reshape(d, d), C[offset:offset + d, offset:offset + d],
                                           rtol=1e-14)
                offset += d
            assert offset == C.shape[0]
    noise = [k for k, (kind, _, _) in enumerate(channels) if kind == "noise"]
    assert all(series.covariances[k].shape[1] == 0 for k in noise)


def test_detector_round_trip_and_streaming_equal_batch(short_mimo, tmp_path):
    model, data = short_mimo
    detector = Detector.train(model, data, 8 * 3600.0, ESTIMATOR)
    process = [s for s, (kind, _, _) in zip(detector._core.scorers, _core.WindowFeatures(model, detector.config).channels)
               if kind == "process"]
    assert all(s.reference_covariance.shape == (len(s.feature_mean),) * 2 for s in process)
    # C_mean = ratio * (C_ref - C_mean): the training windows' mean covariance scaled by the
    # ratio of their layout (73 windows of 2 h every 5 min in 8 h).
    for s in process:
        np.testing.assert_allclose(s.mean_covariance, 0.2928 / 1.2928 * s.reference_covariance, rtol=1e-3)
    batch = detector.monitor(data)
    path = tmp_path / "estimator_detector.json"
    detector.save(path)
    loaded = Detector.load(path)
    assert loaded._core.to_json() == detector._core.to_json()
    np.testing.assert_array_equal(loaded.monitor(data).scores, batch.scores)
    stream = mpmpp.StreamingDetector(loaded)
    windows = stream.push_block(data["time"].to_numpy(), data[list(model.inputs)].to_numpy(),
                                data[list(model.outputs)].to_numpy())
    np.testing.assert_array_equal(np.array([w.scores for w in windows]), batch.scores)
    assert np.isfinite(batch.scores).all()
