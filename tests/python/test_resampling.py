"""mpmpp.resample (paper Section 4.2) against NumPy statistics, a pure-Python re-implementation of
its random stream (std::mt19937_64 + Marsaglia's polar method), and a Kolmogorov-Smirnov test."""
import numpy as np
import pytest
from scipy import stats

import mpmpp
from mpmpp.svm import coefficient_statistics
from mt19937_64 import Mt19937_64


def polar_normals(seed, count):
    rng, out = Mt19937_64(seed), []
    while len(out) < count:
        u = 2.0 * ((rng() >> 11) * 2.0 ** -53) - 1.0
        v = 2.0 * ((rng() >> 11) * 2.0 ** -53) - 1.0
        s = u * u + v * v
        if s >= 1.0 or s == 0.0:
            continue
        f = np.sqrt(-2.0 * np.log(s) / s)
        out += [u * f, v * f]
    return np.array(out[:count])


def test_reference_generator_is_the_standard_one():
    rng = Mt19937_64(5489)
    for _ in range(9999):
        rng()
    assert rng() == 9981545732273789042  # the value the C++ standard requires


def fir_windows(n_windows, m, seed):
    rng = np.random.default_rng(seed)
    gain = 1 + 0.1 * rng.standard_normal(n_windows)
    pole = 0.9 + 0.02 * rng.standard_normal(n_windows)
    return (gain * (1 - pole))[:, None] * pole[:, None] ** np.arange(m)


def test_draws_are_exactly_the_documented_stream():
    windows = fir_windows(5, 7, 1)
    draws = mpmpp.resample(windows, 40, alpha=1.5, seed=12345)
    mu, sd = windows.mean(0), windows.std(0, ddof=1)
    z = polar_normals(12345, 40 * 7).reshape(40, 7)  # row by row
    np.testing.assert_allclose(draws, mu + 1.5 * sd * z, rtol=1e-14, atol=1e-17)


def test_correlated_draws_are_mean_plus_cholesky_factor_times_the_same_stream():
    windows = fir_windows(9, 3, 5)
    draws = mpmpp.resample(windows, 40, alpha=2.0, seed=99, correlated=True)
    S = np.cov(windows, rowvar=False)
    z = polar_normals(99, 40 * 3).reshape(40, 3)  # the same stream as the independent draws
    np.testing.assert_allclose(draws, windows.mean(0) + 2.0 * z @ np.linalg.cholesky(S).T,
                               rtol=0, atol=1e-12)


def test_correlated_draws_have_the_sample_covariance():
    windows = fir_windows(7, 3, 6)  # neighbouring FIR coefficients: correlation near 1
    S = np.cov(windows, rowvar=False)
    n, alpha = 100_000, 1.5
    draws = mpmpp.resample(windows, n, alpha=alpha, seed=3, correlated=True)
    C = np.cov(draws, rowvar=False)
    sd = np.sqrt(np.diag(S))
    np.testing.assert_allclose(C / np.outer(sd, sd), alpha ** 2 * S / np.outer(sd, sd), atol=0.03)
    np.testing.assert_allclose(mpmpp._core.coefficient_covariance(windows), S, rtol=1e-12)


def test_correlated_resampling_needs_a_positive_definite_covariance():
    with pytest.raises(ValueError, match="not positive definite"):
        mpmpp.resample(fir_windows(3, 5, 7), 10, correlated=True)  # 3 windows, 5 coefficients


def test_statistics_match_numpy():
    windows = fir_windows(8, 30, 2)
    mean, std = coefficient_statistics(windows)
    np.testing.assert_allclose(mean, windows.mean(0), rtol=1e-14)
    np.testing.assert_allclose(std, windows.std(0, ddof=1), rtol=1e-12)


def test_moments_and_normality_of_draws():
    windows = fir_windows(6, 10, 3)
    n, alpha = 100_000, 1.5
    draws = mpmpp.resample(windows, n, alpha=alpha, seed=7)
    mu, sd = windows.mean(0), alpha * windows.std(0, ddof=1)
    assert np.all(np.abs(draws.mean(0) - mu) <= 5 * sd / np.sqrt(n))
    np.testing.assert_allclose(draws.std(0, ddof=1) / sd, 1.0, atol=0.01)
    z = (draws - mu) / sd
    assert stats.kstest(z[:, 0], "norm").pvalue > 1e-3
    assert abs(np.corrcoef(z[:, 0], z[:, 1])[0, 1]) < 5 / np.sqrt(n)  # independent coefficients


def test_reproducible_per_seed():
    windows = fir_windows(4, 5, 4)
    a = mpmpp.resample(windows, 500, seed=1)
    np.testing.assert_array_equal(a, mpmpp.resample(windows, 500, seed=1))
    assert not np.array_equal(a, mpmpp.resample(windows, 500, seed=2))
    # alpha = 0 collapses every draw onto the mean
    np.testing.assert_allclose(mpmpp.resample(windows, 3, alpha=0.0), np.tile(windows.mean(0), (3, 1)),
                               rtol=1e-15)


@pytest.mark.parametrize("kwargs,field", [
    ({"features": np.ones((1, 4)), "n": 10}, "features"),
    ({"features": np.array([[0.0, np.nan], [1.0, 2.0]]), "n": 10}, "features"),
    ({"features": np.ones((3, 4)), "n": 0}, "n"),
    ({"features": np.ones((3, 4)), "n": 10, "alpha": -1.0}, "alpha"),
    ({"features": np.ones((3, 4)), "n": 10, "alpha": np.inf}, "alpha"),
    ({"features": np.ones((3, 4)), "n": 10, "seed": -1}, "seed"),
])
def test_bad_input(kwargs, field):
    with pytest.raises(ValueError, match=field):
        mpmpp.resample(**kwargs)
