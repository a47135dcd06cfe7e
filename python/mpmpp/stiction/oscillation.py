"""Oscillation detection by the regularity of the autocorrelation's zero crossings
(Thornhill, Huang & Zhang 2003, J. Process Control 13:91-100).

Horch's and He's tests presuppose an oscillating loop. The intervals between zero crossings
of the autocorrelation function give the period T_p (twice the mean interval); the
oscillation is regular when r = mean(T_p) / (3 std(T_p)) exceeds 1.
"""
from __future__ import annotations

import numpy as np

from .._core import cross_correlation

REGULARITY_THRESHOLD = 1.0   # Thornhill et al.
MIN_CROSSINGS = 4


def regularity(x) -> tuple[float, float]:
    """(regularity r, period in samples); (0, nan) when the ACF has too few zero crossings."""
    x = np.asarray(x, float)
    max_lag = len(x) // 2
    acf = np.asarray(cross_correlation(x, x, max_lag))[max_lag:]
    idx = np.flatnonzero(np.sign(acf[1:]) != np.sign(acf[:-1]))
    crossings = idx + acf[idx] / (acf[idx] - acf[idx + 1])
    if len(crossings) < MIN_CROSSINGS:
        return 0.0, float("nan")
    periods = 2 * np.diff(crossings)
    spread = np.std(periods)
    r = np.inf if spread == 0 else np.mean(periods) / (3 * spread)
    return float(r), float(np.mean(periods))


def is_oscillating(x) -> bool:
    return regularity(x)[0] > REGULARITY_THRESHOLD
