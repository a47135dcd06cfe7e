"""Best onset of an additive step + ramp in the one-step error (a drift on the output)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import TransferFunction


@dataclass
class TrendFit:
    onset: int               # first sample of the step + ramp
    drop: float              # drop of the residual sum of squares against a constant
    trend: np.ndarray        # the fitted step + ramp part, filtered by H^-1 (N long)


def trend_fit(e: np.ndarray, ok: np.ndarray, hinv: TransferFunction, first_onset: int, grid: int,
              earliest: int) -> TrendFit:
    """Least squares of the one-step error e on H^-1 [1, step(t - k), ramp(t - k)] for onsets
    k >= ``earliest`` on a grid (the AR correction is left out: it would whiten a drift away).
    Without a drop, the onset is ``first_onset``."""
    n = len(e)
    t = np.arange(n, dtype=float)
    step0, ramp0 = hinv.filter(np.ones(n)), hinv.filter(t / n)
    base = np.ones(n)
    rss0 = np.sum((e[ok] - e[ok].mean()) ** 2)
    best = TrendFit(first_onset, 0.0, np.zeros(n))
    for k in range(earliest, n - 2 * grid, grid):
        x = np.column_stack([base, np.r_[np.zeros(k), step0[: n - k]], np.r_[np.zeros(k), ramp0[: n - k]]])
        coef = np.linalg.solve(x[ok].T @ x[ok] + 1e-12 * np.eye(3), x[ok].T @ e[ok])
        drop = rss0 - np.sum((e[ok] - x[ok] @ coef) ** 2)
        if drop > best.drop:
            best = TrendFit(k, float(drop), x[:, 1:] @ coef[1:])
    return best
