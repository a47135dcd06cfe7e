"""From held-out likelihood gains to the numbers a finding reports."""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass
class ProfilePoint:
    """A grid value of one effect on one channel, its in-sample statistic and the 95 % interval
    of its scale theta (+- 1.96 se)."""

    label: float
    statistic: float
    theta_ci: tuple = (math.nan, math.nan)


def confidence(score_plus_penalty: float, params: int) -> float:
    """P(chi-square(params) < statistic), Wilson-Hilferty: how unlikely the held-out gain is
    under 'no effect'. Held-out gains can be negative: confidence 0 then."""
    x = max(score_plus_penalty, 0.0)
    if x == 0.0:
        return 0.0
    c = 2.0 / (9.0 * params)
    z = ((x / params) ** (1.0 / 3.0) - (1.0 - c)) / math.sqrt(c)
    return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))


def _near_best(profile: list[ProfilePoint], statistic: float) -> list[ProfilePoint]:
    """The grid points whose statistic is within the chi-square(1) 95 % quantile of the best."""
    return [p for p in profile if p.statistic >= statistic - 3.84]


def ci_from_profile(profile: list[ProfilePoint], statistic: float) -> list:
    """Grid values whose statistic is within the chi-square(1) 95 % quantile of the best."""
    inside = [p.label for p in _near_best(profile, statistic)]
    return [float(min(inside)), float(max(inside))] if inside else [None, None]


def theta_ci_from_profile(profile: list[ProfilePoint], statistic: float) -> list:
    """The union of the theta intervals of the shapes whose statistic is within the chi-square(1)
    95 % quantile of the best: a new channel's gain with the uncertainty of its shape. Routine
    data tell a pole and its gain apart poorly (examples/mimo_missing_coupling: pole 0.9 with
    gain 0.35 and pole 0.95 with gain 0.51 within 2 of each other), and the best shape's own
    interval then misses the truth."""
    inside = [p.theta_ci for p in _near_best(profile, statistic) if math.isfinite(p.theta_ci[0])]
    return [float(min(c[0] for c in inside)), float(max(c[1] for c in inside))] if inside else [None, None]
