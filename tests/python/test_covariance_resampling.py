"""Resampling with the coefficients' covariance (DetectorConfig.resampling = "covariance"):
the whitened SVM catches a gain change hidden by the paper's independent per-coefficient
draws, and the trained detector keeps its decorrelation through a save/load round trip."""
import numpy as np
import pytest

import mpmpp
from mpmpp import _core


def anticorrelated_fir_windows(n_windows=73, seed=0):
    """Two FIR coefficients of a channel whose inputs are strongly autocorrelated: each is
    loose (sd 0.011), their sum, the gain, is precise (sd 0.0035) -- as G11 of the paper
    MIMO example estimates window by window."""
    rng = np.random.default_rng(seed)
    first = 0.06 + 0.011 * rng.standard_normal(n_windows)
    gain = 0.082 + 0.0035 * rng.standard_normal(n_windows)
    return np.column_stack([first, gain - first])


def config(resampling):
    c = mpmpp.DetectorConfig.mimo()  # 2 h windows, 5 min step: 73 windows span 8 h = 4 independent
    c.outlier_fraction = 0.05
    c.resampling = resampling
    c.alpha = 5.0  # the widening these draws need (docs/detection.md)
    c.process_test = c.noise_test = "svm"  # the SVM's resampling is under test, not the Wald tests
    return c


def test_doubled_gain_is_outside_the_covariance_cloud_only():
    X = anticorrelated_fir_windows()
    doubled = 2 * X.mean(0)
    independent = _core.train_channel_scorer(X, config("independent"), seed=1)
    covariance = _core.train_channel_scorer(X, config("covariance"), seed=1)
    assert independent.feature_decorrelation.size == 0
    assert covariance.feature_decorrelation.shape == (2, 2)
    # The independent box is wide along the gain direction: the doubled gain still fits.
    assert independent.score_rows(doubled[None, :])[0] > 0
    assert covariance.score_rows(doubled[None, :])[0] < 0
    # Both accept the training windows' own centre.
    assert independent.score_rows(X.mean(0)[None, :])[0] > 0
    assert covariance.score_rows(X.mean(0)[None, :])[0] > 0


def test_decorrelation_whitens_the_resampled_models():
    X = anticorrelated_fir_windows(seed=3)
    c = config("covariance")
    s = _core.train_channel_scorer(X, c, seed=2)
    Z = mpmpp.resample(X, c.resampled_models, c.alpha, 2, correlated=True)
    z = ((Z - s.feature_mean) / s.feature_scale) @ s.feature_decorrelation.T
    np.testing.assert_allclose(np.cov(z, rowvar=False, ddof=0), np.eye(2) / 2, atol=1e-12)


def test_too_few_independent_windows_fall_back_to_independent_draws():
    X = anticorrelated_fir_windows(n_windows=25)  # 25 windows span 4 h: 2 independent, 2 coefficients
    s = _core.train_channel_scorer(X, config("covariance"), seed=1)
    assert s.feature_decorrelation.size == 0


def test_config_field_round_trips_and_rejects_unknown_values():
    c = mpmpp.DetectorConfig.from_json('{"preset": "paper_mimo", "resampling": "covariance"}')
    assert c.resampling == "covariance"
    assert mpmpp.DetectorConfig.from_json(c.to_json()).resampling == "covariance"
    assert mpmpp.DetectorConfig.paper_mimo().resampling == "independent"  # the paper's Sec. 4.2
    with pytest.raises(ValueError, match="resampling 'full' is not one of independent, covariance"):
        mpmpp.DetectorConfig.from_json('{"resampling": "full"}')
