"""Sample-by-sample monitoring with a trained detector (the C++ StreamingDetector).

Plant software links the C++ library (streaming_detector.hpp); this wrapper gives the same
object to Python users and tests::

    stream = mpmpp.StreamingDetector("detector.json")      # or a trained mpmpp.Detector
    for t, u, y in samples:
        w = stream.push(t, u, y)                           # None until a window completes
        if w is not None and w.alarm_starts: ...
    stream.save_checkpoint("stream.ckpt")                  # resume later: load_checkpoint
"""
from __future__ import annotations

import os

import numpy as np

from . import _core
from .detect import Detector


class StreamingDetector:
    """Pushes samples into a trained detector's moving windows; see streaming_detector.hpp."""

    def __init__(self, detector):
        if isinstance(detector, Detector):
            self._core = _core.StreamingDetector(detector._core)
        elif isinstance(detector, _core.Detector):
            self._core = _core.StreamingDetector(detector)
        elif isinstance(detector, (str, os.PathLike)):
            self._core = _core.StreamingDetector.load(os.fspath(detector))
        else:
            raise ValueError("detector: expected an mpmpp.Detector or a detector file path, "
                             f"got {type(detector).__name__}")

    def push(self, time_s: float, u, y):
        """One sample (u, y in the model's order, NaN when missing): the completed window or None."""
        return self._core.push(float(time_s), np.asarray(u, dtype=float).ravel(), np.asarray(y, dtype=float).ravel())

    def push_block(self, time_s, u, y) -> list:
        """Rows of samples: the windows they complete, in order."""
        u, y = np.asarray(u, dtype=float), np.asarray(y, dtype=float)
        return self._core.push_block(np.asarray(time_s, dtype=float), u.reshape(len(u), -1), y.reshape(len(y), -1))

    def save_checkpoint(self, path) -> None:
        self._core.save_checkpoint(os.fspath(path))

    def load_checkpoint(self, path) -> None:
        self._core.load_checkpoint(os.fspath(path))

    def __getattr__(self, name):  # samples, windows, alarm, window_samples, step_samples, checkpoint_json
        if name == "_core":
            raise AttributeError(name)
        return getattr(self._core, name)
