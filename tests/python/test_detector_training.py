"""Detector training in C++ (``_core.train_detector``, detector_training.hpp) against
independent references: NumPy's SeedSequence for the channel seeds, a plain-Python 64-bit
Mersenne Twister (mt19937_64.py, checked in test_resampling.py) for the cross-validation
shuffle, NumPy for the standardisation, whitening and the resampled cloud's moments,
scikit-learn for the SVM and the cross-validated outlier fraction, and the documented rule
for the training windows and the mean's variance ratio."""
import numpy as np
import pytest
from sklearn.svm import OneClassSVM as SkOneClassSVM

import mpmpp
from mpmpp import _core
from mpmpp.detect import make_config
from mpmpp.evaluate import nominal_model
from mt19937_64 import Mt19937_64

def shuffled_order(n, seed):
    """Fisher-Yates from the last position down, j uniform in [0, i] by masked rejection."""
    engine, order = Mt19937_64(seed), list(range(n))
    for i in range(n - 1, 0, -1):
        mask = (1 << i.bit_length()) - 1
        j = engine() & mask
        while j > i:
            j = engine() & mask
        order[i], order[j] = order[j], order[i]
    return order


def numpy_outlier_offset(scores, f):
    s = np.sort(scores)
    k = min(max(int(np.floor(f * s.size + 0.5)), 1), s.size - 1)
    return 0.5 * (s[k - 1] + s[k])


def numpy_cv(Zs, grid, n_folds, seed, nu, kernel_scale):
    """The cross-validation rule with scikit-learn fits: pooled held-out acceptance per grid
    value, the value whose accuracy is closest to 1 - f (ties to the smaller f)."""
    order = np.array(shuffled_order(len(Zs), seed))
    hits = np.zeros(len(grid))
    for held in np.array_split(order, n_folds):
        train = np.array([i for i in order if i not in set(held)])
        ref = SkOneClassSVM(nu=nu, gamma=1.0 / kernel_scale).fit(Zs[train])
        s_train, s_held = ref.score_samples(Zs[train]), ref.score_samples(Zs[held])
        for k, f in enumerate(grid):
            hits[k] += np.count_nonzero(s_held > numpy_outlier_offset(s_train, f))
    accuracy = hits / len(Zs)
    best = min(range(len(grid)), key=lambda k: (abs(accuracy[k] - (1 - grid[k])), grid[k]))
    return grid[best], accuracy[best]


def numpy_mean_variance_ratio(firsts, window):
    cover = np.zeros(max(firsts) - min(firsts) + window)
    for f in firsts:
        cover[f - min(firsts):f - min(firsts) + window] += 1
    return window * (cover ** 2).sum() / cover.sum() ** 2


def anticorrelated_windows(n=73, seed=0):
    rng = np.random.default_rng(seed)
    first = 0.06 + 0.011 * rng.standard_normal(n)
    gain = 0.082 + 0.0035 * rng.standard_normal(n)
    return np.column_stack([first, gain - first, 0.01 + 0.002 * rng.standard_normal(n)])


def config(**changes):
    c = make_config("mimo")
    # the SVM's training is under test, not the preset's Wald tests
    c.resampling, c.alpha, c.outlier_fraction = "covariance", 3.0, 0.05
    c.process_test = c.noise_test = "svm"
    for k, v in changes.items():
        setattr(c, k, v)
    return c


@pytest.mark.parametrize("seed", [0, 1, 7, 2 ** 32 + 5, 2 ** 63 + 3])
def test_channel_seeds_are_numpy_seed_sequence_words(seed):
    for channel in (0, 1, 5):
        expected = int(np.random.SeedSequence([seed, channel]).generate_state(1, dtype=np.uint64)[0]) >> 1
        assert _core.channel_seed(seed, channel) == expected


def test_cross_validation_shuffle_is_the_documented_fisher_yates():
    X = np.random.default_rng(1).standard_normal((60, 2))
    cv = mpmpp.cross_validate_outlier_fraction(X, (0.05, 0.2), n_folds=3, seed=12345)
    assert list(cv.order) == shuffled_order(60, 12345)


def test_standardisation_whitening_and_svm_match_numpy_and_sklearn():
    X, c = anticorrelated_windows(), config()
    s = _core.train_channel_scorer(X, c, 11)
    Z, correlated = _core.draw_training_models(X, c, 11)
    assert correlated
    mean, scale = Z.mean(0), Z.std(0) * np.sqrt(X.shape[1])
    D = np.linalg.inv(np.linalg.cholesky(np.corrcoef(Z, rowvar=False)))
    Zs = ((Z - mean) / scale) @ D.T
    np.testing.assert_allclose(s.feature_mean, mean, rtol=1e-12)
    np.testing.assert_allclose(s.feature_scale, scale, rtol=1e-12)
    np.testing.assert_allclose(s.feature_decorrelation, D, rtol=1e-10, atol=1e-12)
    ref = SkOneClassSVM(nu=c.nu, gamma=1.0 / c.kernel_scale).fit(Zs)
    assert len(s.dual_coef) == len(ref.support_)
    offset = numpy_outlier_offset(ref.score_samples(Zs), c.outlier_fraction)
    assert s.offset == pytest.approx(offset, rel=1e-6)
    probe = X.mean(0) + 0.02 * np.random.default_rng(4).standard_normal((20, X.shape[1]))
    expected = (ref.score_samples(((probe - mean) / scale) @ D.T) - offset) / (c.nu * len(Zs))
    np.testing.assert_allclose(s.score_rows(probe), expected, atol=1e-6)
    assert (s.n_train, s.training_windows, s.outlier_fraction, s.cv_accuracy) == (300, 73, 0.05, -1.0)


@pytest.mark.parametrize("resampling", ["independent", "covariance"])
def test_resampled_cloud_moments(resampling):
    X = anticorrelated_windows(seed=2)
    c = config(resampling=resampling, resampled_models=100_000)
    Z, correlated = _core.draw_training_models(X, c, 5)
    assert correlated == (resampling == "covariance")
    S = np.cov(X, rowvar=False)
    expected = c.alpha ** 2 * (S if correlated else np.diag(np.diag(S)))
    sd = np.sqrt(np.diag(expected))
    np.testing.assert_allclose(Z.mean(0), X.mean(0), atol=4 * sd.max() / np.sqrt(len(Z)))
    np.testing.assert_allclose(np.cov(Z, rowvar=False), expected, atol=0.02 * np.outer(sd, sd).max())


def test_cross_validated_outlier_fraction_matches_independent_implementation():
    X = anticorrelated_windows(seed=3)
    grid = [0.02, 0.05, 0.1, 0.2]
    c = config(outlier_fraction=-1.0, outlier_fraction_grid=grid, cv_folds=5, resampled_models=200)
    s = _core.train_channel_scorer(X, c, 21)
    Z, _ = _core.draw_training_models(X, c, 21)
    mean, scale = Z.mean(0), Z.std(0) * np.sqrt(X.shape[1])
    Zs = ((Z - mean) / scale) @ np.linalg.inv(np.linalg.cholesky(np.corrcoef(Z, rowvar=False))).T
    fraction, accuracy = numpy_cv(Zs, grid, 5, 21, c.nu, c.kernel_scale)
    assert s.outlier_fraction == fraction
    assert s.cv_accuracy == pytest.approx(accuracy, abs=1e-12)


def test_mean_variance_ratio_matches_numpy():
    rng = np.random.default_rng(0)
    for _ in range(5):
        firsts = sorted(rng.choice(500, size=rng.integers(1, 30), replace=False).tolist())
        window = int(rng.integers(1, 200))
        assert _core.mean_variance_ratio(firsts, window) == pytest.approx(numpy_mean_variance_ratio(firsts, window),
                                                                          rel=1e-14)


@pytest.fixture(scope="module")
def siso_series():
    scen = mpmpp.scenarios.paper_siso()
    scen["duration_s"] = 4 * 3600.0
    scen["events"] = []
    model = nominal_model(scen)
    data = mpmpp.simulate(scen, seed=2)
    data.loc[0:199, "dry_weight"] = np.nan  # more than a tenth of the first windows: they are skipped
    c = make_config({"preset": "paper_siso", "outlier_fraction": 0.05, "resampled_models": 150, "seed": 9})
    time_s = data["time"].to_numpy()
    u, y = data[list(model.inputs)].to_numpy(), data[list(model.outputs)].to_numpy()
    series = _core.WindowFeatures(model, c).extract_series(time_s, u, y)
    return model, c, series, (time_s, u, y)


def test_train_detector_selects_windows_and_seeds_channels_as_documented(siso_series):
    model, c, series, _ = siso_series
    train_end_s = 3 * 3600.0
    detector = _core.train_detector(model, c, series, train_end_s)
    windows = series.windows
    end = windows[0]["start_s"] + train_end_s + 0.5 * model.sample_time_s
    train = [k for k, w in enumerate(windows) if w["end_s"] <= end and not w["skipped"]]
    assert 3 <= len(train) < sum(w["end_s"] <= end for w in windows)  # the NaN windows are left out
    ratio = numpy_mean_variance_ratio([windows[k]["first"] for k in train], c.window_samples(model.sample_time_s))
    kinds = [kind for kind, _, _ in _core.WindowFeatures(model, c).channels]
    for k, trained in enumerate(detector.scorers):
        expected = _core.train_channel_scorer(series.features[k][train], c, _core.channel_seed(c.seed, k),
                                              noise=kinds[k] == "noise", mean_ratio=ratio)
        assert trained.training_windows == len(train)
        np.testing.assert_array_equal(trained.support_vectors, expected.support_vectors)
        assert trained.offset == expected.offset


def test_train_detector_from_raw_data_equals_from_series_and_is_reproducible(siso_series):
    model, c, series, (time_s, u, y) = siso_series
    a = _core.train_detector(model, c, series, 3 * 3600.0)
    b = _core.train_detector(model, c, time_s, u, y, 3 * 3600.0)
    assert a.to_json() == b.to_json()
    c.seed = 10
    assert _core.train_detector(model, c, series, 3 * 3600.0).to_json() != a.to_json()


def test_train_detector_errors(siso_series):
    model, c, series, _ = siso_series
    with pytest.raises(ValueError, match="train_end_s: the training period holds 0 usable windows"):
        _core.train_detector(model, c, series, 3600.0)
    with pytest.raises(ValueError, match="train_end_s: must be a positive number"):
        _core.train_detector(model, c, series, -1.0)
    bad = make_config("paper_siso")
    bad.nu = 2.0
    with pytest.raises(ValueError, match="nu"):
        _core.train_detector(model, bad, series, 3 * 3600.0)
