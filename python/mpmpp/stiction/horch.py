"""Horch's cross-correlation test (Horch 1999, Control Eng. Practice 7:1221-1231).

In a self-regulating loop oscillating because of stiction the OP-PV cross-correlation is
odd (about zero at lag 0); an oscillation from aggressive tuning or an external disturbance
gives an even one (an extremum at lag 0). With tau_l < 0 < tau_r the nearest zero crossings
around lag 0, the index |tau_r + tau_l| / (tau_r - tau_l) is 0 for an even and 1 for an odd
correlation.
"""
from __future__ import annotations

import numpy as np

from .._core import cross_correlation
from .oscillation import REGULARITY_THRESHOLD, regularity

THRESHOLD = 0.23  # chosen on the TUNING families of studies/stiction_benchmark.py


def _first_crossing(r: np.ndarray) -> float:
    """Fractional lag of the first sign change of r[0], r[1], ... (len(r) if none)."""
    for k in range(1, len(r)):
        if np.sign(r[k]) != np.sign(r[k - 1]):
            return k - 1 + r[k - 1] / (r[k - 1] - r[k])
    return float(len(r))


def horch_index(op, pv, max_lag: int = 100) -> float:
    u = np.asarray(op, float)
    y = np.asarray(pv, float)
    max_lag = min(max_lag, len(u) // 3)
    r = np.array(cross_correlation(u, y, max_lag))
    if r[max_lag] == 0.0:  # exactly odd: put the crossing at lag 0 on one side only
        r[max_lag] = np.finfo(float).tiny
    tau_r = _first_crossing(r[max_lag:])
    tau_l = -_first_crossing(r[max_lag::-1])
    return abs(tau_r + tau_l) / (tau_r - tau_l)


def horch_test(op, pv) -> tuple[bool, dict]:
    """Stiction when the PV oscillates regularly and the OP-PV correlation is odd."""
    index = horch_index(op, pv)
    r, _ = regularity(pv)
    return bool(r > REGULARITY_THRESHOLD and index > THRESHOLD), {"index": index, "regularity": r}
