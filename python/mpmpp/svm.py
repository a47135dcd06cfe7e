"""One-class SVM on FIR coefficient vectors (paper Section 4), resampling (Section 4.2) and the
cross-validated choice of the outlier fraction.

The solver (SMO, libsvm's algorithm, reproducing ``sklearn.svm.OneClassSVM`` with
``gamma = 1 / kernel_scale`` to round-off), the resampling and the cross-validation are C++
(``mpmpp._core``). Two scalings of the same solution are exposed:

* scikit-learn / libsvm scaling: ``dual_coef_`` in (0, 1] summing to ``nu * l`` and
  ``decision_function(x) = sum_i dual_coef_i k(sv_i, x) - offset_``;
* the paper's scaling (eqs 18-20): ``alpha_ = dual_coef_ / (nu l)`` summing to 1 and
  ``paper_decision_function(x) = h(x) = sum_i alpha_i k(sv_i, x) - b_`` with
  ``b_ = offset_ / (nu l)``, i.e. ``h = decision_function / (nu l)``. Same sign, so the same
  predictions.
"""
from __future__ import annotations

import warnings
from numbers import Integral, Real

import numpy as np
from sklearn.base import BaseEstimator, OutlierMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils.validation import check_is_fitted, validate_data

from . import _core

__all__ = [
    "OneClassSVM",
    "outlier_offset",
    "cross_validate_outlier_fraction",
    "resample",
    "coefficient_statistics",
]


def outlier_offset(scores, fraction):
    """Offset that makes ``fraction`` of ``scores`` fall below it (MATLAB ``fitcsvm``'s
    OutlierFraction, applied after training; the rule is in detector_training.hpp)."""
    return _core.outlier_offset(np.ascontiguousarray(scores, dtype=np.float64).ravel(), float(fraction))


class OneClassSVM(OutlierMixin, BaseEstimator):
    """nu-one-class SVM with the Gaussian kernel ``k(x, y) = exp(-||x - y||^2 / kernel_scale)``
    (paper eq 15; scikit-learn's ``gamma = 1 / kernel_scale``).

    Parameters
    ----------
    nu : float in (0, 1]
        Upper bound on the fraction of training outliers, lower bound on the fraction of
        support vectors (eq 16).
    kernel_scale : float > 0
        ``c`` of eq (15). The paper uses 1.
    outlier_fraction : float in [0, 1)
        0 keeps the solver's offset (identical to scikit-learn). A positive value shifts the
        offset after training so that this fraction of the training points scores negative
        (see :func:`outlier_offset`); the paper's "outlier rate" (0.05, 0.2).
    tol : float > 0
        SMO stopping tolerance on the maximal KKT violation (scikit-learn's ``tol``).
    cache_mb : float > 0
        Kernel-column cache budget in MB (scikit-learn's ``cache_size``).
    shrinking : bool
        libsvm's shrinking heuristic.
    max_iter : int
        SMO iteration limit, -1 for none; reaching it warns (ConvergenceWarning).
    standardize : bool
        Centre and scale every feature to unit standard deviation (statistics of the training
        set) before the kernel. FIR coefficients are small (1e-3 to 1e-1), so with
        ``kernel_scale = 1`` every pair of models has ``k ~ 1``: the kernel is nearly flat and
        the boundary rests on round-off-level differences. Standardising puts the squared
        distances on the scale of the number of features (choose ``kernel_scale`` of that
        order). Off by default, as in the paper.
    n_threads : int
        Threads for decision_function (1 = serial, <= 0 = hardware concurrency, at most 8).

    Attributes
    ----------
    support_, support_vectors_, dual_coef_ (shape (1, n_SV)), offset_, intercept_ (= -offset_,
    shape (1,)), n_iter_, fit_status_ (0 converged, 1 max_iter reached), n_features_in_;
    solver_offset_ (libsvm's rho before the outlier-fraction shift); alpha_, b_ (paper scaling);
    mean_, scale_ (standardisation, None when off).
    """

    def __init__(self, nu=0.5, kernel_scale=1.0, outlier_fraction=0.0, tol=1e-3, cache_mb=200.0,
                 shrinking=True, max_iter=-1, standardize=False, n_threads=1):
        self.nu = nu
        self.kernel_scale = kernel_scale
        self.outlier_fraction = outlier_fraction
        self.tol = tol
        self.cache_mb = cache_mb
        self.shrinking = shrinking
        self.max_iter = max_iter
        self.standardize = standardize
        self.n_threads = n_threads

    def _check_params(self):
        def real(name, ok, what):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, Real) or not ok(float(v)):
                raise ValueError(f"{name}: must be {what}, got {v!r}")

        real("nu", lambda v: 0.0 < v <= 1.0, "a number in (0, 1]")
        real("kernel_scale", lambda v: 0.0 < v < np.inf, "a finite number > 0")
        real("outlier_fraction", lambda v: 0.0 <= v < 1.0, "a number in [0, 1)")
        real("tol", lambda v: 0.0 < v < np.inf, "a finite number > 0")
        real("cache_mb", lambda v: 0.0 < v < np.inf, "a finite number > 0")
        if isinstance(self.max_iter, bool) or not isinstance(self.max_iter, Integral) or not (
                self.max_iter == -1 or self.max_iter > 0):
            raise ValueError(f"max_iter: must be -1 or a positive integer, got {self.max_iter!r}")
        if isinstance(self.n_threads, bool) or not isinstance(self.n_threads, Integral):
            raise ValueError(f"n_threads: must be an integer, got {self.n_threads!r}")

    def _transform(self, X):
        if self.mean_ is None:
            return X
        return np.ascontiguousarray((X - self.mean_) / self.scale_)

    def fit(self, X, y=None):
        """Train on the rows of X (y is ignored)."""
        self._check_params()
        # The C++ solver rejects NaN/inf in one cheap pass (ValueError naming X), so scikit-learn's
        # finiteness scan is skipped, unless the standardisation has to run on X first.
        X = validate_data(self, X, dtype=np.float64, order="C",
                          ensure_all_finite=bool(self.standardize))
        if self.standardize:
            self.mean_ = X.mean(axis=0)
            scale = X.std(axis=0)
            self.scale_ = np.where(scale > 0, scale, 1.0)
        else:
            self.mean_ = self.scale_ = None
        Z = self._transform(X)
        model = _core.fit_one_class_svm(Z, nu=float(self.nu), kernel_scale=float(self.kernel_scale),
                                        tol=float(self.tol), cache_mb=float(self.cache_mb),
                                        shrinking=bool(self.shrinking),
                                        max_iter=int(self.max_iter))
        self.support_ = np.asarray(model.support, dtype=np.intp)
        self.support_vectors_ = X[self.support_]
        self._kernel_points = model.support_vectors  # in the (possibly standardised) kernel space
        self.dual_coef_ = np.asarray(model.dual_coef).reshape(1, -1)
        self.solver_offset_ = float(model.rho)
        self.n_iter_ = int(model.iterations)
        self.fit_status_ = 0 if model.converged else 1
        self._paper_scale = float(self.nu) * X.shape[0]
        if not model.converged:
            warnings.warn(f"OneClassSVM: max_iter={self.max_iter} reached before tol={self.tol}",
                          ConvergenceWarning, stacklevel=2)
        if self.outlier_fraction > 0:
            self.offset_ = outlier_offset(self._expansion(Z), float(self.outlier_fraction))
        else:
            self.offset_ = self.solver_offset_
        self.intercept_ = np.array([-self.offset_])
        self.alpha_ = self.dual_coef_[0] / self._paper_scale
        self.b_ = self.offset_ / self._paper_scale
        return self

    def _expansion(self, Z):
        return _core.gaussian_kernel_expansion(self._kernel_points, self.dual_coef_[0],
                                               float(self.kernel_scale), Z, int(self.n_threads))

    def _validated(self, X):
        check_is_fitted(self)
        X = validate_data(self, X, dtype=np.float64, order="C", reset=False,
                          ensure_all_finite=self.mean_ is not None)  # else checked in C++
        return self._transform(X)

    def score_samples(self, X):
        """sum_i dual_coef_i k(sv_i, x): the unshifted score (scikit-learn scaling)."""
        return self._expansion(self._validated(X))

    def decision_function(self, X):
        """score_samples(x) - offset_: positive inside the normal region (scikit-learn scaling)."""
        return self.score_samples(X) - self.offset_

    def paper_decision_function(self, X):
        """h(x) of eq (20): decision_function(x) / (nu l)."""
        return self.decision_function(X) / self._paper_scale

    def predict(self, X):
        """+1 for inliers (decision > 0), -1 for outliers (decision <= 0, as libsvm)."""
        return np.where(self.decision_function(X) > 0, 1, -1)

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.allow_nan = False
        return tags


def cross_validate_outlier_fraction(X, fractions=(0.01, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3),
                                    n_folds=10, seed=0, nu=0.5, kernel_scale=1.0, tol=1e-3,
                                    cache_mb=200.0, shrinking=True, max_iter=-1):
    """K-fold cross-validation of the outlier fraction on normal (training) data, the rule
    of detector_training.hpp: the rows are shuffled (``order``, from ``seed``) and cut into
    ``n_folds`` folds; an SVM (the solver parameters) is fitted on all folds but one, and each
    grid value's offset is placed on its training scores. The accuracy of a fraction f is the
    share of held-out rows accepted, pooled over folds; the chosen fraction is the one whose
    accuracy is closest to 1 - f (ties to the smaller f). The paper's 0.9498 at f = 0.05 reads,
    under this definition, as a held-out acceptance rate within 0.1 % of the designed 95 %.

    Returns an object with ``fractions``, ``accuracy``, ``outlier_fraction``,
    ``validation_accuracy``, ``n_folds`` and ``order``."""
    X = np.ascontiguousarray(X, dtype=np.float64)
    if X.ndim != 2:
        raise ValueError(f"X: expected a 2-D array, got shape {X.shape}")
    if isinstance(n_folds, bool) or not isinstance(n_folds, Integral):
        raise ValueError(f"n_folds: must be an integer >= 2, got {n_folds!r}")
    return _core.cross_validate_outlier_fraction(
        X, [float(f) for f in np.ravel(fractions)], int(n_folds), int(seed), nu=float(nu),
        kernel_scale=float(kernel_scale), tol=float(tol), cache_mb=float(cache_mb),
        shrinking=bool(shrinking), max_iter=int(max_iter))


def coefficient_statistics(features):
    """Per-coefficient sample mean and standard deviation (divisor N_k - 1) over the training
    windows (rows of ``features``), paper Section 4.2."""
    return _core.coefficient_statistics(np.ascontiguousarray(features, dtype=np.float64))


def resample(features, n, alpha=1.5, seed=0, correlated=False):
    """n synthetic FIR models, coefficient i ~ N(mu_i, (alpha sigma_i)^2) independently
    (paper Section 4.2), from the training-window estimates ``features`` (N_k x m, N_k >= 2).
    ``correlated=True``: rows ~ N(mu, alpha^2 S) with the coefficients' sample covariance S
    (mpmpp's extension, see resampling.hpp; ValueError when S is not positive definite).
    Deterministic per seed (std::mt19937_64 + Marsaglia's polar method, see resampling.hpp)."""
    if isinstance(n, bool) or not isinstance(n, Integral):
        raise ValueError(f"n: must be an integer, got {n!r}")
    if isinstance(seed, bool) or not isinstance(seed, Integral) or seed < 0:
        raise ValueError(f"seed: must be a non-negative integer, got {seed!r}")
    return _core.resample(np.ascontiguousarray(features, dtype=np.float64), int(n), float(alpha),
                          int(seed), bool(correlated))
