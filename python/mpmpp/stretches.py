"""A record's complete stretches laid end to end, for fits that use all of them.

A historian export with scattered missing values or time gaps is several complete stretches. A
fit over all of them treats each as its own experiment: every filter starts at rest at a
stretch's first row, no lag reaches across a gap, and a criterion that skips a start-up of
``t0`` rows skips it in every stretch. Nothing is interpolated across a gap. The C++ estimators
take the same layout as ``stretch_starts`` (``mpmpp.identify.arx`` / ``oe`` / ``arx_oe``).
"""
from __future__ import annotations

import numpy as np


class Stretches:
    """Rows [bounds[k], bounds[k + 1]) of the laid-out record are stretch k."""

    def __init__(self, lengths):
        lengths = [int(n) for n in lengths]
        if not lengths or min(lengths) < 1:
            raise ValueError(f"stretches need at least one row each, got lengths {lengths}")
        self.bounds = np.r_[0, np.cumsum(lengths)]

    @property
    def rows(self) -> int:
        return int(self.bounds[-1])

    @property
    def starts(self) -> list[int]:
        """Rows where a new stretch begins (the estimators' ``stretch_starts``)."""
        return [int(b) for b in self.bounds[1:-1]]

    def spans(self):
        return zip(self.bounds[:-1].tolist(), self.bounds[1:].tolist())

    def filter(self, tf, x: np.ndarray) -> np.ndarray:
        """tf (a ``TransferFunction``) applied to x (one column), each stretch from rest."""
        return np.asarray(tf.filter(np.ascontiguousarray(x, dtype=float), stretch_starts=self.starts))

    def filter_columns(self, tf, x: np.ndarray) -> np.ndarray:
        """``filter`` applied to every column of x."""
        return np.column_stack([self.filter(tf, x[:, j]) for j in range(x.shape[1])])

    def lag(self, x: np.ndarray, k: int) -> np.ndarray:
        """x delayed by k rows in every stretch, zeros before each stretch's first row."""
        return np.concatenate([np.r_[np.zeros(min(k, b - a)), x[a:max(b - k, a)]] for a, b in self.spans()])

    def after(self, t0: int) -> np.ndarray:
        """Mask of the rows at least t0 rows into their stretch (a criterion's common range)."""
        mask = np.zeros(self.rows, dtype=bool)
        for a, b in self.spans():
            mask[a + t0:b] = True
        return mask

    def cumsum(self, x: np.ndarray) -> np.ndarray:
        """Running sums from each stretch's first row (the level across a gap is unknown)."""
        return np.concatenate([np.cumsum(x[a:b], axis=0) for a, b in self.spans()])

    def demeaned(self, x: np.ndarray) -> np.ndarray:
        """x less its mean in every stretch."""
        return np.concatenate([x[a:b] - x[a:b].mean(axis=0) for a, b in self.spans()])

    def differenced(self, x: np.ndarray) -> np.ndarray:
        """(1 - q^-1) x in every stretch, 0 at each stretch's first row."""
        return np.concatenate([np.r_[0.0, np.diff(x[a:b])] for a, b in self.spans()])
