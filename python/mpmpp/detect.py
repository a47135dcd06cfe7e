"""Moving-window MPM and noise-change detection (paper Sections 2 and 4).

``detect(model, data, train_end_s)`` trains on the windows that end inside the training
period and monitors every window of ``data``; ``Detector`` keeps the trained detector to
monitor new data later (``save`` / ``load``: the versioned file a C++ program reads too).

Division of labour: the C++ core (``mpmpp._core``) extracts the per-window ARX-OE features,
scores windows, computes the indicator (eq. 23) and alarms, and reads/writes the detector
file. This module orchestrates training: per channel, resampling of the training-window
estimates (Sec. 4.2), standardisation, the cross-validated outlier fraction and the
one-class SVM fit (``mpmpp.svm``), then hands the trained parts to the core.
"""
from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Optional, Union

import numpy as np
import pandas as pd

from . import _core
from ._core import DetectorConfig
from .svm import OneClassSVM, cross_validate_outlier_fraction, resample

__all__ = ["DetectorConfig", "Detector", "DetectionResult", "detect", "make_config"]

ConfigLike = Union[None, str, dict, "os.PathLike[str]", DetectorConfig]


def make_config(config: ConfigLike = None, model=None) -> DetectorConfig:
    """A DetectorConfig from: None (the recommended preset for the model's size: ``siso``
    for one output, ``mimo`` otherwise), a preset name (``siso``, ``mimo``, or the paper's
    Tables 1/3 verbatim: ``paper_siso``, ``paper_mimo``), a dict or a JSON file path
    (``{"preset": ..., field: value, ...}``; unknown keys are an error), or a DetectorConfig."""
    if isinstance(config, DetectorConfig):
        config.validate()
        return config
    if config is None:
        n_outputs = len(model.outputs) if model is not None else 1
        return DetectorConfig.siso() if n_outputs == 1 else DetectorConfig.mimo()
    if isinstance(config, dict):
        return DetectorConfig.from_json(json.dumps(config))
    text = os.fspath(config)
    if text in ("siso", "mimo", "paper_siso", "paper_mimo"):
        return DetectorConfig.preset(text)
    try:
        with open(text, encoding="utf-8") as f:
            body = f.read()
    except OSError as exc:
        raise ValueError(f"{text}: cannot read the detector config ({exc.strerror})") from None
    try:
        return DetectorConfig.from_json(body)
    except ValueError as exc:
        raise ValueError(f"{text}: {exc}") from None


def _arrays(model, data: pd.DataFrame):
    """time (s), u (N x inputs), y (N x outputs) in the model's column order."""
    missing = [c for c in ["time", *model.inputs, *model.outputs] if c not in data.columns]
    if missing:
        raise ValueError(f"data: column '{missing[0]}' of the model is missing")
    as_float = lambda cols: np.ascontiguousarray(data[cols].to_numpy(dtype=float))  # noqa: E731
    return (np.ascontiguousarray(data["time"].to_numpy(dtype=float)), as_float(list(model.inputs)),
            as_float(list(model.outputs)))


def _channel_seed(seed: int, channel: int) -> int:
    # Independent, reproducible streams per channel from the one user seed.
    return int(np.random.SeedSequence([int(seed), channel]).generate_state(1, dtype=np.uint64)[0]
               >> np.uint64(1))


def _independent_windows(n_windows: int, config: DetectorConfig) -> int:
    """Non-overlapping windows spanned by n_windows consecutive moving windows."""
    return int((config.window_s + (n_windows - 1) * config.step_s) // config.window_s)


def mean_variance_ratio(firsts, window: int) -> float:
    """Covariance of the mean of the window estimates starting at samples ``firsts`` (each
    ``window`` samples long), relative to one window's. An estimate is, to first order, the
    average of its samples' contributions, so the mean weights sample t by the number of
    windows covering it, w_t: ratio = window * sum(w_t^2) / (sum w_t)^2 (1/n for n disjoint
    windows, 1 for identical ones; 0.29 for the 73 windows of 8 h at a 5 min step)."""
    firsts = np.asarray(firsts, dtype=np.int64)
    if firsts.size == 0 or window < 1:
        raise ValueError("mean_variance_ratio: needs at least one window of >= 1 sample")
    lo = int(firsts.min())
    cover = np.zeros(int(firsts.max()) - lo + window)
    np.add.at(cover, (firsts - lo)[:, None] + np.arange(window), 1.0)
    return float(window * (cover ** 2).sum() / cover.sum() ** 2)


def _directional_max(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """A^1/2 max(I, A^-1/2 B A^-1/2) A^1/2 (max on eigenvalues; A positive definite): in the
    coordinates where A is the identity, B's eigenvalues below 1 are raised to 1, so the
    result is at least A and at least B (Loewner order)."""
    w, V = np.linalg.eigh(A)
    if not w.min() > 0:
        raise ValueError("the training windows' OE covariance is not positive definite")
    root, inv_root = (V * np.sqrt(w)) @ V.T, (V / np.sqrt(w)) @ V.T
    e, U = np.linalg.eigh(inv_root @ B @ inv_root)
    V2 = root @ (U * np.maximum(e, 1.0)) @ U.T @ root
    return 0.5 * (V2 + V2.T)


def _draw_models(X: np.ndarray, config: DetectorConfig, seed: int, reference_covariance, noise: bool):
    """Sec. 4.2's synthetic models for one channel, and whether they are correlated."""
    n = int(config.resampled_models)
    alpha = float(config.noise_alpha if noise and config.noise_alpha > 0 else config.alpha)
    if reference_covariance is not None:
        # Resampling 'estimator': N(mu, alpha^2 V), V the larger of C_ref and S in every
        # direction. C_ref (reference_covariance: the training windows' mean two-step
        # covariance plus their mean's) is computed from every sample, so it is sound even
        # when the training period spans only a few independent windows; S, the sample
        # covariance of the window estimates, takes over where the real spread exceeds it.
        # With R = C_ref^1/2: V = R max(I, R^-1 S R^-1) R, the max taken on eigenvalues.
        sample = np.cov(X, rowvar=False).reshape(X.shape[1], X.shape[1])
        spread = _directional_max(reference_covariance, sample)
        return _core.draw_correlated_gaussian_models(X.mean(axis=0), spread, n, alpha, int(seed)), True
    correlated = config.resampling == "covariance" and _independent_windows(X.shape[0], config) > X.shape[1]
    try:
        # N synthetic models, coefficient i ~ N(mu_i, (alpha sigma_i)^2), or with the
        # coefficients' covariance (DetectorConfig.resampling).
        return resample(X, n, alpha, seed, correlated=correlated), correlated
    except ValueError:
        if not correlated:
            raise
        # A singular covariance (a coefficient that never varies, collinear estimates): the
        # paper's independent draws, as documented for Resampling::Covariance.
        return resample(X, n, alpha, seed), False


def train_scorer(estimates: np.ndarray, config: DetectorConfig, seed: int,
                 covariances: Optional[np.ndarray] = None, noise: bool = False,
                 mean_ratio: float = 0.0) -> _core.ChannelScorer:
    """The trained SVM of one channel from its training-window estimates (rows) and, with
    resampling 'estimator' on a process channel, their covariances (rows of d^2) and
    mean_ratio, the covariance of their mean relative to one window's (mean_variance_ratio).
    noise: a noise-model channel (widened by config.noise_alpha when set)."""
    X = np.asarray(estimates, dtype=float)
    d = X.shape[1]
    reference = mean_covariance = None
    if config.resampling == "estimator" and covariances is not None and np.size(covariances):
        window = np.asarray(covariances, dtype=float).mean(axis=0).reshape(d, d)
        window = 0.5 * (window + window.T)
        # The frame a window like the training ones maps to itself in: its own covariance
        # plus that of the training mean it is compared with (ChannelScorer.mean_covariance).
        mean_covariance = float(mean_ratio) * window
        reference = window + mean_covariance
    Z, correlated = _draw_models(X, config, seed, reference, noise)
    if config.standardise:
        # FIR coefficients are ~0.01-0.1, so with the paper's c = 1 the raw kernel
        # exp(-||x - y||^2) is ~1 everywhere and the SVM degenerates to a sphere in the
        # largest coefficients. Centring and scaling each coefficient by the resampled spread,
        # and the vector by 1/sqrt(d), makes ||z - z'||^2 average 2 over the cloud whatever d,
        # so c = 1 gives a kernel that is neither flat nor spiky on every channel.
        mean = Z.mean(axis=0)
        scale = Z.std(axis=0) * np.sqrt(d)
        scale = np.where(scale > 0, scale, 1.0)  # a coefficient that never varies (alpha sigma = 0)
    else:
        mean, scale = np.zeros(d), np.ones(d)
    Zs = (Z - mean) / scale
    decorrelation = np.zeros((0, 0))
    if correlated and config.standardise:
        # Whitening: with R the correlation matrix of the resampled models and R = L L',
        # z = L^-1 (x - mean) / (std sqrt(d)) has covariance I / d, so the kernel with c = 1
        # measures Mahalanobis distance: a shift along a precise direction (the gain) counts
        # as much as along a loose one.
        decorrelation = np.linalg.inv(np.linalg.cholesky(np.corrcoef(Z, rowvar=False)))
        Zs = Zs @ decorrelation.T
    Zs = np.ascontiguousarray(Zs)
    cv_accuracy = -1.0
    if config.outlier_fraction >= 0:
        fraction = float(config.outlier_fraction)
    else:
        cv = cross_validate_outlier_fraction(Zs, fractions=list(config.outlier_fraction_grid),
                                             n_folds=int(config.cv_folds), seed=seed,
                                             nu=float(config.nu), kernel_scale=float(config.kernel_scale))
        fraction, cv_accuracy = cv.outlier_fraction, cv.validation_accuracy
    svm = OneClassSVM(nu=float(config.nu), kernel_scale=float(config.kernel_scale),
                      outlier_fraction=fraction).fit(Zs)
    s = _core.ChannelScorer()
    s.feature_mean, s.feature_scale, s.feature_decorrelation = mean, scale, decorrelation
    if reference is not None:
        s.reference_covariance, s.mean_covariance = reference, mean_covariance
    s.support_vectors = np.ascontiguousarray(Zs[svm.support_])
    s.dual_coef = np.asarray(svm.dual_coef_[0], dtype=float)
    s.offset = float(svm.offset_)
    s.kernel_scale, s.nu, s.n_train = float(config.kernel_scale), float(config.nu), int(Zs.shape[0])
    s.training_windows, s.outlier_fraction, s.cv_accuracy = int(X.shape[0]), fraction, float(cv_accuracy)
    return s


def _channel_dicts(model, core_channels):
    out = []
    for kind, i, j in core_channels:
        c = {"kind": kind, "output": model.outputs[i]}
        if kind == "process":
            c["input"] = model.inputs[j]
        out.append(c)
    return out


def channel_label(channel: dict) -> str:
    """G[y <- u] for a process channel, H[y] for a noise channel."""
    if channel["kind"] == "noise":
        return f"H[{channel['output']}]"
    return f"G[{channel['output']} <- {channel['input']}]"


@dataclass
class DetectionResult:
    """Scores, indicator and alarms of every window (see ``to_dict`` for the JSON form)."""

    train_end_s: float
    threshold: float
    channels: list            # dicts: kind, output[, input]
    windows: pd.DataFrame     # start_s, end_s, training, skipped, skip_reason
    scores: np.ndarray        # windows x channels; 0 in training, NaN when skipped
    indicator: np.ndarray     # windows x channels (eq. 23)
    alarms: list              # dicts: kind, output[, input], start_s, channel (index)
    training: list = field(default_factory=list)  # per channel: windows, outlier fraction, cv accuracy

    def alarm_starts(self, channel: int) -> np.ndarray:
        return np.array([a["start_s"] for a in self.alarms if a["channel"] == channel])

    def to_dict(self) -> dict:
        """FORMATS.md ``detect --json``; skipped windows (NaN scores) are listed apart."""
        keep = ~self.windows["skipped"].to_numpy(bool)
        windows = [{"start_s": float(w.start_s), "end_s": float(w.end_s),
                    "scores": [float(v) for v in s], "indicator": [float(v) for v in ind]}
                   for w, s, ind in zip(self.windows[keep].itertuples(), self.scores[keep], self.indicator[keep])]
        skipped = [{"start_s": float(w.start_s), "end_s": float(w.end_s), "reason": w.skip_reason}
                   for w in self.windows[~keep].itertuples()]
        alarms = [{k: v for k, v in a.items() if k != "channel"} for a in self.alarms]
        return {"train_end_s": float(self.train_end_s), "channels": list(self.channels), "windows": windows,
                "alarms": alarms, "threshold": float(self.threshold), "skipped_windows": skipped}

    def alarm_table(self, stamp=None) -> str:
        """Human summary: one line per channel with its alarm start times, written by
        ``stamp(t)`` (default: hours of the ``time`` column)."""
        stamp = stamp or (lambda t: f"{t / 3600:.2f} h")
        width = max([len("channel")] + [len(channel_label(c)) for c in self.channels])
        lines = [f"{'channel':<{width}}  {'kind':<6} alarms (start)"]
        for k, c in enumerate(self.channels):
            starts = self.alarm_starts(k)
            text = ", ".join(stamp(s) for s in starts) if starts.size else "none"
            lines.append(f"{channel_label(c):<{width}}  {'MPM' if c['kind'] == 'process' else 'noise':<6} {text}")
        n_skipped = int(self.windows["skipped"].sum())
        if n_skipped:
            lines.append(f"{n_skipped} window(s) skipped (missing values or not informative)")
        return "\n".join(lines)


class Detector:
    """A trained detector: ``Detector.train(model, data, train_end_s, config)``, then
    ``monitor(data)``; ``save(path)`` / ``Detector.load(path)``."""

    def __init__(self, core: _core.Detector):
        self._core = core

    @property
    def model(self):
        return self._core.model

    @property
    def config(self) -> DetectorConfig:
        return self._core.config

    @property
    def train_end_s(self) -> float:
        return self._core.train_end_s

    @staticmethod
    def _train_from_series(model, config, series, channels, train_end_s):
        windows = series.windows
        t0 = windows[0]["start_s"] if windows else 0.0
        train = [k for k, w in enumerate(windows)
                 if w["end_s"] <= t0 + train_end_s + 0.5 * model.sample_time_s and not w["skipped"]]
        if len(train) < 3:
            n_in = sum(1 for w in windows if w["end_s"] <= t0 + train_end_s + 0.5 * model.sample_time_s)
            raise ValueError(f"train_end_s: the training period holds {len(train)} usable windows "
                             f"({n_in} in all, window {config.window_s:g} s, step {config.step_s:g} s); "
                             "need at least 3")
        covariances = series.covariances
        ratio = mean_variance_ratio([windows[k]["first"] for k in train], config.window_samples(model.sample_time_s))
        scorers = [train_scorer(series.features[k][train], config, _channel_seed(config.seed, k),
                                covariances[k][train] if covariances else None, noise=channels[k][0] == "noise",
                                mean_ratio=ratio)
                   for k in range(len(series.features))]
        return _core.Detector(model, config, float(train_end_s), scorers)

    @classmethod
    def train(cls, model, data: pd.DataFrame, train_end_s: Optional[float] = None,
              config: ConfigLike = None) -> "Detector":
        return cls._train(model, data, train_end_s, config)[0]

    @classmethod
    def _train(cls, model, data, train_end_s, config):
        config = make_config(config, model)
        if train_end_s is None:
            train_end_s = config.train_duration_s
        if not np.isfinite(train_end_s) or train_end_s <= 0:
            raise ValueError(f"train_end_s: must be a positive number of seconds, got {train_end_s}")
        time_s, u, y = _arrays(model, data)
        features = _core.WindowFeatures(model, config)
        series = features.extract_series(time_s, u, y)
        return cls(cls._train_from_series(model, config, series, features.channels, float(train_end_s))), series

    def monitor(self, data: pd.DataFrame) -> DetectionResult:
        time_s, u, y = _arrays(self.model, data)
        return self._result(self._core.monitor(time_s, u, y))

    def _result(self, r) -> DetectionResult:
        model = self.model
        channels = _channel_dicts(model, _core.WindowFeatures(model, self.config).channels)
        windows = pd.DataFrame(r.windows, columns=["first", "start_s", "end_s", "skipped", "skip_reason"])
        windows["training"] = np.asarray(r.training, dtype=bool)
        alarms = []
        for k, _, start in r.alarms:
            alarms.append({**channels[k], "start_s": float(start), "channel": int(k)})
        training = [{"windows": s.training_windows, "outlier_fraction": s.outlier_fraction,
                     "cv_accuracy": None if s.cv_accuracy < 0 else s.cv_accuracy} for s in self._core.scorers]
        return DetectionResult(train_end_s=self.train_end_s, threshold=self.config.threshold, channels=channels,
                               windows=windows, scores=np.asarray(r.scores), indicator=np.asarray(r.indicator),
                               alarms=alarms, training=training)

    def save(self, path) -> None:
        """Versioned JSON file (written atomically) that Python or C++ can load."""
        self._core.save(os.fspath(path))

    @classmethod
    def load(cls, path) -> "Detector":
        return cls(_core.Detector.load(os.fspath(path)))


def detect(model, data: pd.DataFrame, train_end_s: Optional[float] = None, config: ConfigLike = None,
           return_detector: bool = False):
    """Train on the windows ending within ``train_end_s`` seconds of the first sample (default:
    the config's ``train_duration_s``) and monitor every window of ``data``.

    Returns a DetectionResult, or (DetectionResult, Detector) with ``return_detector``."""
    detector, series = Detector._train(model, data, train_end_s, config)
    result = detector._result(detector._core.monitor_series(series))
    return (result, detector) if return_detector else result
