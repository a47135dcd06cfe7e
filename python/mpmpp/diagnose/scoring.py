"""From held-out likelihood gains to the numbers a finding reports."""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass
class ProfilePoint:
    """A grid value of one effect on one channel and its in-sample statistic."""

    label: float
    statistic: float


def confidence(score_plus_penalty: float, params: int) -> float:
    """P(chi-square(params) < statistic), Wilson-Hilferty: how unlikely the held-out gain is
    under 'no effect'. Held-out gains can be negative: confidence 0 then."""
    x = max(score_plus_penalty, 0.0)
    if x == 0.0:
        return 0.0
    c = 2.0 / (9.0 * params)
    z = ((x / params) ** (1.0 / 3.0) - (1.0 - c)) / math.sqrt(c)
    return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))


def ci_from_profile(profile: list[ProfilePoint], statistic: float) -> list:
    """Grid values whose statistic is within the chi-square(1) 95 % quantile of the best."""
    inside = [p.label for p in profile if p.statistic >= statistic - 3.84]
    return [float(min(inside)), float(max(inside))] if inside else [None, None]
