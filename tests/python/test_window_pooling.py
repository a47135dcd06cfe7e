"""Pooled residual Wald test (config pooled_windows, cpp/include/mpmpp/window_pooling.hpp): each
monitored window's coefficients are pooled with those of the disjoint windows before it; where
the training agrees with the model (model_reference_significance) the window is judged against
the model and the training mean together (ChannelScorer::confirmation). The scores against a
plain NumPy implementation of the same equations on the detector's own window estimates, and
the streaming detector (with a checkpoint in the middle) against the batch path."""
import numpy as np
import pytest
from scipy.stats import chi2

from mpmpp import StreamingDetector, families
from mpmpp.detect import Detector
from mpmpp.evaluate import nominal_model
from mpmpp.simulate import simulate

RANK_TOLERANCE = 1e-9  # ChannelScorer::kWaldRankTolerance


def _pinv(m):
    lam, v = np.linalg.eigh(m)
    inv = np.where(lam > RANK_TOLERANCE * lam.max(), 1.0 / np.where(lam > 0, lam, 1.0), 0.0)
    return (v * inv) @ v.T


def pooled(estimates, covariances):
    """Precision-weighted mean and its covariance, pseudo-inverses in correlation form."""
    scale = np.sqrt(np.mean([np.diag(c) for c in covariances], axis=0))
    inv = np.where(scale > 0, 1.0 / np.where(scale > 0, scale, 1.0), 0.0)
    precisions = [_pinv(inv[:, None] * c * inv[None, :]) for c in covariances]
    cov = _pinv(sum(precisions))
    mean = cov @ sum(p @ (inv * x) for p, x in zip(precisions, estimates))
    return scale * mean, scale[:, None] * cov * scale[None, :]


def wald_log10_p(deviation, s):
    """log10 p of the Wald test of deviation ~ N(0, s) (correlation form)."""
    inv = 1.0 / np.sqrt(np.diag(s))
    lam, v = np.linalg.eigh(inv[:, None] * s * inv[None, :])
    keep = lam > RANK_TOLERANCE * lam.max()
    t = np.sum((v[:, keep].T @ (inv * deviation)) ** 2 / lam[keep])
    return chi2.logsf(t, keep.sum()) / np.log(10)


def wald_score(x, cov, mean, mean_cov, level, confirmation=0.0):
    """log10(p / level) of the Wald test of x against the training mean; with a confirmation,
    the intersection-union test with the one against the model (beta = 0, no reference
    variance): log10 max(p_0 / level, p / confirmation)."""
    training = wald_log10_p(x - mean, cov + mean_cov)
    if confirmation == 0:
        return training - np.log10(level)
    return max(wald_log10_p(x, cov) - np.log10(level), training - np.log10(confirmation))


def training_model_p(features, covs, training, lag):
    """p of the training's coefficients, pooled over the disjoint windows ending at its last
    one, against the model (beta = 0)."""
    d = features.shape[1]
    last = np.flatnonzero(training)[-1]
    members = [w for w in range(last, -1, -lag) if np.all(np.isfinite(features[w]))]
    x, c = pooled([features[w] for w in members], [covs[w].reshape(d, d) for w in members])
    return 10 ** wald_log10_p(x, c)


@pytest.fixture(scope="module")
def loop():
    spec, _ = families.family("pi_siso").draw(3, record_s=10 * 3600.0)
    model = nominal_model(spec)
    return model, simulate(spec)


@pytest.mark.parametrize("pooled_windows", [2, 3])
def test_scores_match_numpy(loop, pooled_windows):
    model, data = loop
    config = {"preset": "siso", "pooled_windows": pooled_windows}
    detector, series = Detector._train(model, data, None, config)
    result = detector.monitor(data)
    lag = detector.config.pooling_lag(model.sample_time_s)
    assert lag == round(detector.config.window_s / detector.config.step_s)  # whole steps in the presets
    k = next(i for i, c in enumerate(result.channels) if c["kind"] == "process")
    scorer = detector._core.scorers[k]
    features, covs = np.asarray(series.features[k]), np.asarray(series.covariances[k])
    d = features.shape[1]
    checked = 0
    training = result.windows["training"].to_numpy()
    model_p = training_model_p(features, covs, training, lag)
    assert scorer.model_p_value == pytest.approx(model_p, rel=1e-6)
    assert model_p > detector.config.model_reference_significance  # the exact model: judged against it
    assert scorer.confirmation == detector.config.training_confirmation
    for w in np.flatnonzero(~training):
        members = [w - m * lag for m in range(pooled_windows) if w - m * lag >= 0]
        members = [m for m in members if np.all(np.isfinite(features[m]))]
        x, c = pooled([features[m] for m in members], [covs[m].reshape(d, d) for m in members])
        expected = wald_score(x, c, np.asarray(scorer.feature_mean), np.asarray(scorer.mean_covariance),
                              detector.config.window_significance, scorer.confirmation)
        assert result.scores[w, k] == pytest.approx(expected, rel=1e-6, abs=1e-6)
        checked += len(members) == pooled_windows
    assert checked > 10  # most windows pooled the full count
    alone = Detector._train(model, data, None, {**config, "pooled_windows": 1})[0].monitor(data).scores[:, k]
    assert not np.allclose(alone, result.scores[:, k])  # pooling changed the scores


def test_stream_with_checkpoint_equals_batch(loop):
    model, data = loop
    detector = Detector.train(model, data, None, {"preset": "siso", "pooled_windows": 2})
    batch = detector.monitor(data)
    time_s = data["time"].to_numpy()
    u, y = data[list(model.inputs)].to_numpy(), data[list(model.outputs)].to_numpy()
    cut = len(time_s) // 2
    first = StreamingDetector(detector)
    windows = first.push_block(time_s[:cut], u[:cut], y[:cut])
    resumed = StreamingDetector(detector)
    resumed.restore_checkpoint_json(first.checkpoint_json(), "checkpoint")
    windows += resumed.push_block(time_s[cut:], u[cut:], y[cut:])
    assert len(windows) == len(batch.windows)
    np.testing.assert_array_equal(np.array([w.scores for w in windows]), batch.scores)
    starts = [(k, w.end_s) for w in windows for k in w.alarm_starts]
    assert starts == [(a["channel"], a["start_s"]) for a in batch.alarms]


def test_bad_pooled_windows_names_the_field(loop):
    model, data = loop
    with pytest.raises(ValueError, match="pooled_windows"):
        Detector.train(model, data, None, {"preset": "siso", "pooled_windows": 0})
