"""mpmpp.OneClassSVM against sklearn.svm.OneClassSVM (libsvm), the outlier-fraction shift and
cross-validation against plain NumPy/scikit-learn re-implementations, degenerate input, and
scikit-learn's estimator checks."""
import warnings
import zlib

import numpy as np
import pytest
from sklearn.datasets import make_blobs
from sklearn.svm import OneClassSVM as SkOneClassSVM
from sklearn.utils.estimator_checks import check_estimator

import mpmpp
from mpmpp import _core
from mpmpp.svm import cross_validate_outlier_fraction, outlier_offset


# ----------------------------------------------------------------------------- datasets
def gaussian(rng, n, d):
    return rng.standard_normal((n, d))


def blobs(rng, n, d):
    X, _ = make_blobs(n_samples=n, n_features=d, centers=3, cluster_std=0.7,
                      random_state=int(rng.integers(1 << 30)))
    return X


def student_t(rng, n, d):
    return rng.standard_t(df=2, size=(n, d))


def cauchy(rng, n, d):
    return rng.standard_cauchy((n, d))


def duplicated(rng, n, d):
    base = rng.standard_normal((n // 5, d))
    return base[rng.integers(0, base.shape[0], n)]


def grid_ties(rng, n, d):
    return rng.integers(0, 5, (n, d)).astype(float)


def uniform(rng, n, d):
    return rng.uniform(-1, 1, (n, d))


def mixed_scales(rng, n, d):
    return rng.standard_normal((n, d)) * np.logspace(-3, 3, d)


def low_rank(rng, n, d):
    return rng.standard_normal((n, 2)) @ rng.standard_normal((2, d))


def fir_cloud(rng, n, m, delay=0, two_regimes=False):
    """Impulse responses g_k = K (1 - a) a^(k - delay) of first-order models with perturbed gain
    and pole plus estimation noise: the FIR vectors the ARX-OE windows produce."""
    gain = 1.0 + 0.1 * rng.standard_normal(n)
    if two_regimes:
        gain[: n // 4] *= 2.0  # a mismatched cluster
    pole = np.clip(0.9 + 0.02 * rng.standard_normal(n), 0.5, 0.99)
    k = np.arange(m) - delay
    g = np.where(k >= 0, (gain * (1 - pole))[:, None] * pole[:, None] ** np.maximum(k, 0), 0.0)
    return g + 0.005 * rng.standard_normal((n, m))


# (name, generator, n, d, nu, kernel_scale, extra solver options)
CASES = [
    ("gauss-50x2", gaussian, 50, 2, 0.5, 1.0, {}),
    ("gauss-200x5", gaussian, 200, 5, 0.1, 5.0, {}),
    ("gauss-500x10", gaussian, 500, 10, 0.3, 10.0, {}),
    ("gauss-1000x30", gaussian, 1000, 30, 0.5, 30.0, {}),
    ("gauss-800x120", gaussian, 800, 120, 0.05, 120.0, {}),
    ("blobs-600x2", blobs, 600, 2, 0.2, 1.0, {}),
    ("blobs-1500x8", blobs, 1500, 8, 0.05, 4.0, {}),
    ("student-800x3", student_t, 800, 3, 0.1, 2.0, {}),
    ("cauchy-400x6", cauchy, 400, 6, 0.5, 6.0, {}),
    ("dup-500x4", duplicated, 500, 4, 0.3, 4.0, {}),
    ("dup-300x2", duplicated, 300, 2, 0.05, 1.0, {}),
    ("grid-ties-400x2", grid_ties, 400, 2, 0.5, 2.0, {}),
    ("uniform-2000x3", uniform, 2000, 3, 0.5, 0.5, {}),
    ("mixed-scales-700x5", mixed_scales, 700, 5, 0.2, 100.0, {}),
    ("low-rank-800x20", low_rank, 800, 20, 0.3, 20.0, {}),
    ("fir-500x30-c1", lambda r, n, d: fir_cloud(r, n, d), 500, 30, 0.5, 1.0, {}),
    ("fir-2000x60", lambda r, n, d: fir_cloud(r, n, d), 2000, 60, 0.5, 0.01, {}),
    ("fir-1000x50-delay-regimes", lambda r, n, d: fir_cloud(r, n, d, 3, True), 1000, 50, 0.2,
     0.1, {}),
    ("fir-300x120", lambda r, n, d: fir_cloud(r, n, d, 5), 300, 120, 0.05, 0.05, {}),
    ("gauss-5000x10", gaussian, 5000, 10, 0.1, 10.0, {}),
    ("gauss-20000x2", gaussian, 20000, 2, 0.05, 1.0, {}),
    ("noshrink-1000x10", gaussian, 1000, 10, 0.5, 10.0, {"shrinking": False}),
    ("tight-tol-300x4", gaussian, 300, 4, 0.2, 4.0, {"tol": 1e-7}),
    ("small-cache-3000x10", gaussian, 3000, 10, 0.5, 10.0, {"cache_mb": 0.5}),
    ("nu-0.97-100x3", gaussian, 100, 3, 0.97, 3.0, {}),
]


@pytest.mark.parametrize("name,gen,n,d,nu,c,opts", CASES, ids=[c[0] for c in CASES])
def test_matches_sklearn(name, gen, n, d, nu, c, opts):
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    X = gen(rng, n, d)
    X_test = np.vstack([gen(rng, 200, d), 3 * gen(rng, 50, d)])  # fresh and far-away points
    tol = opts.get("tol", 1e-3)
    ref = SkOneClassSVM(nu=nu, gamma=1.0 / c, tol=tol, shrinking=opts.get("shrinking", True),
                        cache_size=opts.get("cache_mb", 200.0)).fit(X)
    ours = mpmpp.OneClassSVM(nu=nu, kernel_scale=c, **opts).fit(X)

    scale = np.max(np.abs(ref.score_samples(X)))
    for Z in (X, X_test):
        d_ref, d_ours = ref.decision_function(Z), ours.decision_function(Z)
        assert np.max(np.abs(d_ours - d_ref)) <= 1e-6 * scale
        np.testing.assert_allclose(ours.score_samples(Z), ref.score_samples(Z), rtol=0,
                                   atol=1e-6 * scale)
        decided = np.abs(d_ref) > 1e-6 * scale  # a tie at 0 may go either way
        assert np.array_equal(ours.predict(Z)[decided], ref.predict(Z)[decided])
    assert abs(ours.offset_ - ref.offset_[0]) <= 1e-6 * scale

    # Same support set; a point may differ only if its coefficient is at round-off level (a tie).
    ours_alpha, ref_alpha = np.zeros(n), np.zeros(n)
    ours_alpha[ours.support_] = ours.dual_coef_[0]
    ref_alpha[ref.support_] = ref.dual_coef_[0]
    differ = np.setxor1d(ours.support_, ref.support_)
    assert np.all(np.maximum(ours_alpha[differ], ref_alpha[differ]) <= 1e-9)
    np.testing.assert_allclose(ours_alpha, ref_alpha, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(ours.support_vectors_, X[ours.support_])

    # Paper scaling (eqs 18-20): alpha sums to 1 within the box [0, 1/(nu l)], h = f / (nu l).
    assert abs(ours.alpha_.sum() - 1.0) < 1e-9
    assert np.all(ours.alpha_ <= 1.0 / (nu * n) * (1 + 1e-12))
    np.testing.assert_allclose(ours.paper_decision_function(X_test),
                               ours.decision_function(X_test) / (nu * n), rtol=1e-12, atol=0)


def test_standardize_matches_sklearn_on_standardized_data():
    rng = np.random.default_rng(7)
    X = fir_cloud(rng, 400, 40)
    Z = (X - X.mean(0)) / X.std(0)
    ref = SkOneClassSVM(nu=0.5, gamma=1.0 / 40).fit(Z)
    ours = mpmpp.OneClassSVM(nu=0.5, kernel_scale=40.0, standardize=True).fit(X)
    X_new = fir_cloud(rng, 100, 40)
    Z_new = (X_new - X.mean(0)) / X.std(0)
    scale = np.max(np.abs(ref.score_samples(Z)))
    assert np.max(np.abs(ours.decision_function(X_new) - ref.decision_function(Z_new))) <= 1e-6 * scale
    np.testing.assert_array_equal(ours.support_, ref.support_)


def test_decision_function_threads_agree():
    rng = np.random.default_rng(3)
    X = gaussian(rng, 3000, 8)
    svm = mpmpp.OneClassSVM(nu=0.2, kernel_scale=8.0).fit(X)
    one = svm.decision_function(X)
    svm.set_params(n_threads=2)
    np.testing.assert_allclose(svm.decision_function(X), one, rtol=0, atol=1e-12)


# ------------------------------------------------------------------ outlier fraction and CV
def test_outlier_fraction_flags_that_share_of_training_points():
    rng = np.random.default_rng(11)
    X = blobs(rng, 1000, 3)
    for f in (0.05, 0.2):
        svm = mpmpp.OneClassSVM(nu=0.5, kernel_scale=3.0, outlier_fraction=f).fit(X)
        assert np.count_nonzero(svm.decision_function(X) < 0) == round(f * 1000)
        # Reference: midpoint of the k-th and (k+1)-th smallest libsvm scores.
        s = np.sort(SkOneClassSVM(nu=0.5, gamma=1 / 3.0).fit(X).score_samples(X))
        k = round(f * 1000)
        assert svm.offset_ == pytest.approx(0.5 * (s[k - 1] + s[k]), rel=1e-9)
        assert svm.solver_offset_ != svm.offset_
        assert svm.b_ == pytest.approx(svm.offset_ / (0.5 * 1000), rel=1e-12)


def test_outlier_offset_edge_cases():
    assert outlier_offset([3.0], 0.1) == 3.0
    assert outlier_offset([1.0, 2.0, 3.0, 4.0], 0.01) == 1.5  # at least one point flagged
    assert outlier_offset([1.0, 2.0, 3.0, 4.0], 0.99) == 3.5  # never all of them
    with pytest.raises(ValueError, match="fraction"):
        outlier_offset([1.0, 2.0], 0.0)


def test_cross_validation_matches_plain_sklearn_reference():
    rng = np.random.default_rng(5)
    X = gaussian(rng, 300, 4)
    grid = (0.02, 0.05, 0.1, 0.2)
    cv = cross_validate_outlier_fraction(X, grid, n_folds=10, seed=3, nu=0.5, kernel_scale=4.0)
    # Independent re-implementation: the same shuffled order (checked against a plain-Python
    # Mersenne Twister in test_detector_training.py), libsvm fits, numpy offsets.
    order = np.asarray(cv.order)
    assert sorted(order) == list(range(300))
    hits = np.zeros(len(grid))
    for held in np.array_split(order, 10):
        train = np.setdiff1d(order, held, assume_unique=True)
        ref = SkOneClassSVM(nu=0.5, gamma=0.25).fit(X[train])
        s_train = np.sort(ref.score_samples(X[train]))
        s_held = ref.score_samples(X[held])
        for k, f in enumerate(grid):
            j = min(max(int(np.floor(f * len(train) + 0.5)), 1), len(train) - 1)
            hits[k] += np.count_nonzero(s_held > 0.5 * (s_train[j - 1] + s_train[j]))
    np.testing.assert_array_equal(cv.accuracy, hits / 300)
    gap = np.abs(cv.accuracy - (1 - np.array(grid)))
    assert cv.outlier_fraction == grid[int(np.argmin(gap))]
    assert cv.validation_accuracy == cv.accuracy[grid.index(cv.outlier_fraction)]
    assert cv.n_folds == 10


def test_cross_validation_bad_input():
    X = np.zeros((30, 2))
    with pytest.raises(ValueError, match="fractions"):
        cross_validate_outlier_fraction(X, (0.0, 0.1))
    with pytest.raises(ValueError, match="n_folds"):
        cross_validate_outlier_fraction(X, n_folds=1)
    with pytest.raises(ValueError, match="rows"):
        cross_validate_outlier_fraction(X[:10], n_folds=10)


# ------------------------------------------------------------------------- degenerate input
def test_single_sample_documented_result():
    X = np.array([[1.0, 2.0]])
    ours = mpmpp.OneClassSVM(nu=0.5).fit(X)
    ref = SkOneClassSVM(nu=0.5, gamma=1.0).fit(X)
    assert ours.decision_function(X)[0] == pytest.approx(0.0, abs=1e-15)
    assert ours.predict(X)[0] == ref.predict(X)[0] == -1
    assert ours.offset_ == pytest.approx(ref.offset_[0])


def test_identical_points_documented_result():
    X = np.ones((50, 3))
    ours = mpmpp.OneClassSVM(nu=0.3, kernel_scale=2.0).fit(X)
    ref = SkOneClassSVM(nu=0.3, gamma=0.5).fit(X)
    np.testing.assert_allclose(ours.decision_function(X), 0.0, atol=1e-12)
    assert ours.offset_ == pytest.approx(ref.offset_[0], rel=1e-12)
    np.testing.assert_array_equal(ours.support_, ref.support_)
    assert np.all(ours.predict(X + 1.0) == -1)


def test_nu_one_documented_result():
    # Every alpha is at the bound and rho is not unique; libsvm's choice is +inf (scikit-learn
    # then refuses the model). Ours is the smallest optimal rho: the best training point scores 0.
    X = np.random.default_rng(2).standard_normal((60, 3))
    svm = mpmpp.OneClassSVM(nu=1.0, kernel_scale=3.0).fit(X)
    np.testing.assert_array_equal(svm.dual_coef_[0], np.ones(60))
    K = np.exp(-((X[:, None, :] - X[None, :, :]) ** 2).sum(-1) / 3.0)
    assert svm.offset_ == pytest.approx(K.sum(1).max(), rel=1e-6)
    assert svm.decision_function(X).max() == pytest.approx(0.0, abs=1e-5)


@pytest.mark.parametrize("X", [np.array([[0.0, np.nan], [1.0, 2.0]]),
                               np.array([[0.0, np.inf], [1.0, 2.0]])])
def test_non_finite_input_rejected(X):
    with pytest.raises(ValueError):
        mpmpp.OneClassSVM().fit(X)
    with pytest.raises(ValueError, match="X"):
        _core.fit_one_class_svm(X)
    svm = mpmpp.OneClassSVM().fit(np.eye(3)[:, :2])
    with pytest.raises(ValueError):
        svm.decision_function(X)


@pytest.mark.parametrize("params,field", [
    ({"nu": 0.0}, "nu"), ({"nu": 1.5}, "nu"), ({"nu": -0.1}, "nu"), ({"nu": np.nan}, "nu"),
    ({"kernel_scale": 0.0}, "kernel_scale"), ({"kernel_scale": -1.0}, "kernel_scale"),
    ({"kernel_scale": np.inf}, "kernel_scale"), ({"outlier_fraction": 1.0}, "outlier_fraction"),
    ({"tol": 0.0}, "tol"), ({"cache_mb": 0}, "cache_mb"), ({"max_iter": 0}, "max_iter"),
])
def test_bad_parameters_rejected(params, field):
    X = np.random.default_rng(0).standard_normal((20, 2))
    with pytest.raises(ValueError, match=field):
        mpmpp.OneClassSVM(**params).fit(X)
    core_args = {k: v for k, v in params.items() if k != "outlier_fraction"}
    if core_args:
        with pytest.raises(ValueError, match=field):
            _core.fit_one_class_svm(X, **core_args)


def test_max_iter_warns_and_reports_status():
    X = np.random.default_rng(0).standard_normal((500, 5))
    with pytest.warns(Warning, match="max_iter"):
        svm = mpmpp.OneClassSVM(nu=0.5, kernel_scale=5.0, max_iter=3).fit(X)
    assert svm.fit_status_ == 1 and svm.n_iter_ == 3
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = SkOneClassSVM(nu=0.5, gamma=0.2, max_iter=3).fit(X)
    np.testing.assert_allclose(svm.decision_function(X), ref.decision_function(X), atol=1e-9)


def test_wrong_feature_count_rejected():
    svm = mpmpp.OneClassSVM().fit(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="features"):
        svm.predict(np.zeros((2, 4)))
    with pytest.raises(ValueError, match="X"):
        _core.gaussian_kernel_expansion(np.zeros((2, 3)), np.ones(2), 1.0, np.zeros((2, 4)))


# ------------------------------------------------------------------------------ scikit-learn
def test_check_estimator():
    # Every check applies and passes; the only one scikit-learn skips is check_array_api_input
    # (needs SCIPY_ARRAY_API, and the C++ solver takes NumPy float64 only).
    results = check_estimator(mpmpp.OneClassSVM(), on_fail=None)
    failed = [(r["check_name"], str(r["exception"])) for r in results if r["status"] == "failed"]
    assert failed == []
    skipped = {r["check_name"] for r in results if r["status"] == "skipped"}
    assert skipped <= {"check_array_api_input"}


def test_get_set_params_round_trip():
    svm = mpmpp.OneClassSVM(nu=0.2, kernel_scale=3.0, outlier_fraction=0.05)
    p = svm.get_params()
    assert p["nu"] == 0.2 and p["kernel_scale"] == 3.0 and p["outlier_fraction"] == 0.05
    svm.set_params(nu=0.4)
    assert svm.nu == 0.4
