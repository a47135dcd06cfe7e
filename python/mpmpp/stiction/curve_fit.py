"""He et al.'s curve-fitting test (He, Wang, Pottmann & Qin 2007, IECR 46:4549-4560).

Stiction makes the OP of a self-regulating loop (the PV of an integrating one) triangular,
a linear oscillation is sinusoidal. Each half cycle between zero crossings is fitted with a
half sine and with a triangle (apex position free); the stiction index is
  SI = MSE_sine / (MSE_sine + MSE_triangle),
above 0.5 when triangles fit better. The loop type is not known here, so the larger of the
OP's and the PV's index is used.
"""
from __future__ import annotations

import numpy as np

from .oscillation import REGULARITY_THRESHOLD, regularity

THRESHOLD = 0.67  # He et al. use 0.6; chosen on the TUNING families of the benchmark
MIN_HALF = 4      # samples per half cycle


def _half_cycle_errors(seg: np.ndarray) -> tuple[float, float]:
    m = len(seg)
    t = (np.arange(m) + 0.5) / m
    basis = np.sin(np.pi * t)
    sine_err = np.sum((seg - basis * (basis @ seg) / (basis @ basis)) ** 2)
    tri_err = np.inf
    for apex in np.linspace(0.1, 0.9, 17):
        tri = np.where(t < apex, t / apex, (1 - t) / (1 - apex))
        tri_err = min(tri_err, np.sum((seg - tri * (tri @ seg) / (tri @ tri)) ** 2))
    return float(sine_err), float(tri_err)


def stiction_index(x) -> float:
    """SI over the half cycles of x (NaN when x has no half cycle of >= MIN_HALF samples)."""
    x = np.convolve(np.asarray(x, float), np.ones(3) / 3, mode="valid")
    x = x - x.mean()
    crossings = np.flatnonzero(np.sign(x[1:]) != np.sign(x[:-1])) + 1
    sine = tri = 0.0
    for a, b in zip(crossings[:-1], crossings[1:]):
        if b - a >= MIN_HALF:
            s, t = _half_cycle_errors(x[a:b])
            sine += s
            tri += t
    if sine + tri == 0:
        return float("nan")
    return sine / (sine + tri)


def curve_fit_test(op, pv) -> tuple[bool, dict]:
    """Stiction when the loop oscillates regularly and a triangle fits better than a sine."""
    si_op, si_pv = stiction_index(op), stiction_index(pv)
    si = float(np.nanmax([si_op, si_pv])) if np.isfinite([si_op, si_pv]).any() else float("nan")
    r, _ = regularity(pv)
    return bool(r > REGULARITY_THRESHOLD and si > THRESHOLD), {"SI": si, "SI_op": si_op,
                                                              "SI_pv": si_pv, "regularity": r}
