"""Continuous refinement of a grid estimate (a time-constant factor).

The structure search picks a grid point; the value itself lies anywhere between its
neighbours. A bounded 1-D minimisation (Brent's method, SciPy) of the criterion the grid
was searched with, between the two neighbouring grid points, gives the value.
"""
from __future__ import annotations

from typing import Callable

from scipy.optimize import minimize_scalar

REFINE_TOLERANCE = 1e-3       # relative width of the final bracket (well below the grid spacing)


def neighbours(grid: tuple, value: float, lowest: float, highest: float) -> tuple[float, float]:
    """The grid points either side of ``value`` (a grid point); past the grid's ends, the
    bound the parameter allows (``lowest`` / ``highest``)."""
    ordered = sorted(grid)
    k = ordered.index(value)
    return (ordered[k - 1] if k > 0 else lowest), (ordered[k + 1] if k + 1 < len(ordered) else highest)


def refine(criterion: Callable[[float], float], grid: tuple, best: float, lowest: float,
           highest: float) -> float:
    """The value between ``best``'s grid neighbours that minimises ``criterion``; ``best``
    itself when the minimiser does not improve on it (a flat or noisy criterion)."""
    lo, hi = neighbours(grid, best, lowest, highest)
    res = minimize_scalar(criterion, bounds=(lo, hi), method="bounded",
                          options={"xatol": REFINE_TOLERANCE * (hi - lo)})
    return float(res.x) if res.success and res.fun < criterion(best) else best
