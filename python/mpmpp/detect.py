"""Moving-window MPM and noise-change detection (paper Sections 2 and 4).

``detect(model, data, train_end_s)`` trains on the windows that end inside the training
period and monitors every window of ``data``; ``Detector`` keeps the trained detector to
monitor new data later (``save`` / ``load``: the versioned file a C++ program reads too).

The numerics are in the C++ core (``mpmpp._core``): per-window features (ARX-OE estimates,
or for ``process_test: "residual"`` the residual regression of residual_regression.hpp),
training (``train_detector``: resampling, standardisation, cross-validated outlier fraction,
one-class SVM, or the Wald test's training mean; detector_training.hpp), scoring, the
indicator (eq. 23) and alarms, and the detector file. This module turns user input (configs,
data frames) into core calls and results into tables and JSON.
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
from .disturbance import WHITENING_FLOOR, describe, disturbance_orders
from .preset_timing import TIMING_FIELDS, fit_to_record, resolve_timing, span_text
from .held_values import (frozen_columns, frozen_note, require_computable, require_moving_outputs,
                          require_recorded_columns)
from .signals import through_actuators
from .timeaxis import seconds_of

__all__ = ["DetectorConfig", "Detector", "DetectionResult", "detect", "make_config"]

ConfigLike = Union[None, str, dict, "os.PathLike[str]", DetectorConfig]


def make_config(config: ConfigLike = None, model=None, record_s: Optional[float] = None,
                train_end_s: Optional[float] = None) -> DetectorConfig:
    """A DetectorConfig from: None (the recommended preset for the model's size: ``siso``
    for one output, ``mimo`` otherwise), a preset name (``siso``, ``mimo``, or the paper's
    Tables 1/3 verbatim: ``paper_siso``, ``paper_mimo``), a dict or a JSON file path
    (``{"preset": ..., field: value, ...}``; unknown keys are an error), or a DetectorConfig.
    A preset's durations the user did not set are resolved at the model's sample time and,
    given the span of the monitored record (``record_s``) and the user's end of training if any,
    fitted to that record (mpmpp.preset_timing); explicit values and a DetectorConfig are taken
    as they are."""
    return _configure(config, model, record_s, train_end_s)[0]


def _configure(config: ConfigLike, model, record_s: Optional[float] = None,
               train_end_s: Optional[float] = None) -> tuple:
    """(config, notes): make_config's config and the notes saying how a preset was resolved at
    the model's sample time and fitted to the record."""
    if isinstance(config, DetectorConfig):
        config.validate()
        return config, []
    where = None
    if config is None:
        n_outputs = len(model.outputs) if model is not None else 1
        given = {"preset": "siso" if n_outputs == 1 else "mimo"}
    elif isinstance(config, dict):
        given = config
    else:
        text = os.fspath(config)
        if text in ("siso", "mimo", "paper_siso", "paper_mimo"):
            given = {"preset": text}
        else:
            where = text
            given = _config_file(text)
    try:
        resolved = DetectorConfig.from_json(json.dumps(given))
        preset = given.get("preset")
        if preset is None or model is None:
            return resolved, []
        explicit = set(given) & set(TIMING_FIELDS)
        resolved, timing = resolve_timing(resolved, preset, model.sample_time_s, explicit=explicit)
        notes = [timing] if timing else []
        if record_s is not None:
            resolved, fitted = fit_to_record(resolved, model.sample_time_s, record_s, set(given), train_end_s)
            notes += [fitted] if fitted else []
        return resolved, notes
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}" if where else str(exc)) from None


def _config_file(path: str):
    """The JSON document of a detector config file (a non-object is left to the config parser
    to refuse)."""
    try:
        with open(path, encoding="utf-8") as f:
            body = f.read()
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the detector config ({exc.strerror})") from None
    try:
        return json.loads(body)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: detector config is not valid JSON ({exc.msg}, line {exc.lineno})") from None


def _arrays(model, data: pd.DataFrame):
    """time (s), u (N x inputs), y (N x outputs) in the model's column order. An input with a
    valve in the model file's actuators block is its simulated valve position: the valve is
    there throughout, so the windows' ARX-OE estimates the linear part seen through it."""
    missing = [c for c in ["time", *model.inputs, *model.outputs] if c not in data.columns]
    if missing:
        raise ValueError(f"data: column '{missing[0]}' of the model is missing")
    as_float = lambda cols: np.ascontiguousarray(data[cols].to_numpy(dtype=float))  # noqa: E731
    time_s = np.ascontiguousarray(seconds_of(data))
    raw_u, y = as_float(list(model.inputs)), as_float(list(model.outputs))
    require_computable([*model.inputs, *model.outputs], np.column_stack([raw_u, y]), time_s)
    u = np.ascontiguousarray(through_actuators(model, raw_u))
    require_moving_outputs(model.outputs, y)
    return time_s, u, y


def _channel_dicts(model, core_channels):
    out = []
    modelled = set(model.channels())
    for kind, i, j in core_channels:
        c = {"kind": kind, "output": model.outputs[i]}
        if kind == "process":
            c["input"] = model.inputs[j]
            if (c["output"], c["input"]) not in modelled:  # config absent_channels
                c["in_model"] = False
        out.append(c)
    return out


STANDING_ERROR_P = 1e-3


def _reference_notes(core: _core.Detector, channels: list) -> list:
    """A note per channel (``channels``: _channel_dicts of the detector's) whose training data
    reject the model (DetectorConfig::
    model_reference_significance): the model is off already there, and the channel is judged
    against the training alone. Noted only at p < STANDING_ERROR_P: at the gate's own 5 % level
    one exact channel in twenty would be, one MIMO run in three with nine channels (the
    detector file and DetectionResult.training keep every channel's p)."""
    return [f"{channel_label(c)}: the training data reject the model (Wald test p = {s.model_p_value:.2g}); "
            "judged against the training alone, so an MPM alarm means a change since training "
            "(mpmpp diagnose names the standing error)"
            for c, s in zip(channels, core.scorers)
            if 0 <= s.model_p_value < STANDING_ERROR_P and s.confirmation == 0]


def channel_label(channel: dict) -> str:
    """G[y <- u] for a process channel, H[y] for a noise channel."""
    return _core.channel_label(channel["output"], channel.get("input", "") if channel["kind"] == "process" else "")


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
    notes: list = field(default_factory=list)     # what detect assumed or estimated on the user's behalf
    # The trained core detector and its core result: the C++ writer (detector_io) formats them.
    core: tuple = field(default=None, repr=False, compare=False)

    def alarm_starts(self, channel: int) -> np.ndarray:
        return np.array([a["start_s"] for a in self.alarms if a["channel"] == channel])

    def to_dict(self) -> dict:
        """docs/formats.md ``detect --json``; skipped windows are listed apart with the reason;
        ``notes``: what detect estimated on the user's behalf (e.g. a disturbance model)."""
        return {**json.loads(_core.detection_json(*self.core)), "notes": list(self.notes)}

    def save_json(self, path) -> None:
        """The ``to_dict`` document as a file, written atomically."""
        from .io import atomic_output

        with atomic_output(path) as f:
            json.dump(self.to_dict(), f)

    def alarm_table(self, stamp=None) -> str:
        """Human summary: one line per channel with its alarm start times, written by
        ``stamp(t)`` (default: hours of the ``time`` column)."""
        stamp = stamp or (lambda t: f"{t / 3600:.2f} h")
        width = max([len("channel")] + [len(channel_label(c)) for c in self.channels])
        lines = [f"{'channel':<{width}}  {'kind':<6} alarms (start)"]
        for k, c in enumerate(self.channels):
            starts = self.alarm_starts(k)
            text = ", ".join(stamp(s) for s in starts) if starts.size else "none"
            absent = " (a channel the model lacks: a coupling appeared)" if starts.size and c.get("in_model") is False else ""
            lines.append(f"{channel_label(c):<{width}}  {'MPM' if c['kind'] == 'process' else 'noise':<6} {text}{absent}")
        n_skipped = int(self.windows["skipped"].sum())
        if n_skipped:
            lines.append(f"{n_skipped} window(s) skipped (missing values or not informative)")
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)


class Detector:
    """A trained detector: ``Detector.train(model, data, train_end_s, config)``, then
    ``monitor(data)``; ``save(path)`` / ``Detector.load(path)``."""

    def __init__(self, core: _core.Detector, notes: Optional[list] = None):
        self._core = core
        self.notes = list(notes or [])  # from training; a detector loaded from a file has none

    @property
    def model(self):
        return self._core.model

    @property
    def config(self) -> DetectorConfig:
        return self._core.config

    @property
    def train_end_s(self) -> float:
        return self._core.train_end_s

    @classmethod
    def train(cls, model, data: pd.DataFrame, train_end_s: Optional[float] = None,
              config: ConfigLike = None) -> "Detector":
        return cls._train(model, data, train_end_s, config)[0]

    @classmethod
    def _train(cls, model, data, train_end_s, config, monitored: bool = False):
        """monitored: the same data is monitored after training, so it must hold one window
        after the training period."""
        time_s, u, y = _arrays(model, data)
        if not len(time_s):
            raise ValueError("data: no rows to train on")
        require_recorded_columns(model.inputs, u, model.outputs, y)   # training needs every column
        record_s = record_span(time_s, model.sample_time_s) if monitored else None
        config, timing = _configure(config, model, record_s, train_end_s)
        if train_end_s is None:
            train_end_s = config.train_duration_s
        if monitored:
            _check_record(config, model.sample_time_s, time_s, float(train_end_s))
        config, notes = _cover_disturbance(config, model, time_s, u, y, float(train_end_s))
        features = _core.WindowFeatures(model, config)
        series = features.extract_series(time_s, u, y)
        core = _core.train_detector(model, config, series, float(train_end_s))
        still = [frozen_note(name) for name in frozen_columns(model.inputs, u)]
        return cls(core, still + timing + notes + _reference_notes(core, _channel_dicts(model, features.channels))), series

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
                     "cv_accuracy": None if s.cv_accuracy < 0 else s.cv_accuracy,
                     "model_p_value": None if s.model_p_value < 0 else s.model_p_value,
                     "model_reference": s.confirmation > 0} for s in self._core.scorers]
        return DetectionResult(train_end_s=self.train_end_s, threshold=self.config.threshold, channels=channels,
                               windows=windows, scores=np.asarray(r.scores), indicator=np.asarray(r.indicator),
                               alarms=alarms, training=training, notes=self.notes, core=(self._core, r))

    def save(self, path) -> None:
        """Versioned JSON file (written atomically) that Python or C++ can load."""
        self._core.save(os.fspath(path))

    @classmethod
    def load(cls, path) -> "Detector":
        return cls(_core.Detector.load(os.fspath(path)))


def _check_record(config: DetectorConfig, sample_time_s: float, time_s, train_end_s: float) -> None:
    """A one-line error when the record does not reach the training end plus one window."""
    span = record_span(time_s, sample_time_s)
    window = config.window_samples(sample_time_s) * sample_time_s
    needed = train_end_s + window
    if span < needed - 1e-6 * sample_time_s:
        raise ValueError(f"data: the record spans {span_text(span)}; detection needs at least "
                         f"{span_text(needed)} at {sample_time_s:g} s sampling (training "
                         f"{span_text(train_end_s)} plus one {span_text(window)} window); `compare` and "
                         f"`diagnose` judge a shorter record without a training period")


def record_span(time_s, sample_time_s: float) -> float:
    """Seconds a record covers: first to last sample plus the last sample's period."""
    return float(time_s[-1] - time_s[0]) + sample_time_s


def _cover_disturbance(config: DetectorConfig, model, time_s, u, y, train_end_s: float):
    """(config, notes): the config with the ARX order raised to the disturbance models' AR order
    where it falls short (mpmpp.disturbance), the residual test's whitening order and
    moving-average root per output set to its disturbance's when the config leaves the order
    open (``residual_ar_order`` 0), and a note per
    output whose disturbance model was estimated from the training rows because the model file
    has none."""
    open_order = str(config.process_test) == "residual" and config.residual_ar_order == 0 and not config.residual_ar_orders
    orders = disturbance_orders(model, time_s, u, y, train_end_s, config.window_samples(model.sample_time_s),
                                whitening=open_order)
    needed = max([config.arx_order_a] + [d.order for d in orders])
    whitening, roots = [], []
    if open_order:
        whitening = [needed if d.whitening is None else max(WHITENING_FLOOR, d.whitening) for d in orders]
        roots = [d.whitening_root for d in orders] if any(d.whitening_root for d in orders) else []
    if needed != config.arx_order_a or whitening:
        config = DetectorConfig.from_json(config.to_json())
        config.arx_order_a = needed
        config.residual_ar_orders = whitening
        config.residual_ma_roots = roots
    return config, [describe(d, needed, whitening[k] if whitening else None)
                    for k, d in enumerate(orders) if d.estimated]


def detect(model, data: pd.DataFrame, train_end_s: Optional[float] = None, config: ConfigLike = None,
           return_detector: bool = False):
    """Train on the windows ending within ``train_end_s`` seconds of the first sample (default:
    the config's ``train_duration_s``) and monitor every window of ``data``.

    Returns a DetectionResult, or (DetectionResult, Detector) with ``return_detector``."""
    detector, series = Detector._train(model, data, train_end_s, config, monitored=True)
    result = detector._result(detector._core.monitor_series(series))
    return (result, detector) if return_detector else result
