"""A finding's confidence: the probability that it is right, from the evidence it carries.

The held-out likelihood gain alone (its chi-square CDF, ``scoring.confidence``) is ~1 for every
finding on long closed-loop records, right or wrong. What tells a right finding from a wrong
one is how much evidence it has relative to the record, whether its update lowers the held-out
errors (a finding whose update barely lowers them is not a confident one), and how large the
input-explained part of the error is against the disturbance. A logistic map of these features
is fitted on the TUNING scenario families only (studies/calibrate_confidence.py writes
confidence_map.json); its reliability is reported on the held-out families
(studies/diagnosis_families.py, docs/diagnose.md).
"""
from __future__ import annotations

import json
import math
from functools import lru_cache
from pathlib import Path

import numpy as np

from .result import PROCESS_EFFECTS

MAP_FILE = Path(__file__).with_name("confidence_map.json")
FEATURES = ("log_score", "one_step_fall", "process_fall", "process_share", "process_effect")


def _ratio_fall(before, after) -> float:
    """1 - after / before, clipped to [-1, 1]; 0 when either is unknown."""
    if before is None or after is None or not (before > 0) or not math.isfinite(after):
        return 0.0
    return float(np.clip(1.0 - after / before, -1.0, 1.0))


def features(finding: dict) -> np.ndarray:
    """The evidence of one finding (``Finding.to_dict()`` plus its ``score``)."""
    pb, eb = finding.get("process_error_before"), finding.get("error_before")
    share = math.log(pb / eb) if pb and eb and pb > 0 and eb > 0 else math.log(1e-3)
    return np.array([
        math.log1p(max(float(finding.get("score", 0.0)), 0.0)),
        _ratio_fall(eb, finding.get("error_after")),
        _ratio_fall(pb, finding.get("process_error_after")),
        max(share, math.log(1e-3)),
        1.0 if finding["effect"] in PROCESS_EFFECTS else 0.0,
    ])


def fit_map(findings: list[dict], labels: list[bool], regularisation: float = 1.0) -> dict:
    """Logistic regression of right/wrong on the standardised features (scikit-learn)."""
    from sklearn.linear_model import LogisticRegression

    x = np.array([features(f) for f in findings])
    y = np.asarray(labels, dtype=int)
    if len(set(y)) < 2:
        raise ValueError("calibration needs right and wrong findings")
    mean, scale = x.mean(axis=0), x.std(axis=0)
    scale[scale == 0] = 1.0
    model = LogisticRegression(C=regularisation).fit((x - mean) / scale, y)
    return {"features": list(FEATURES), "mean": mean.tolist(), "scale": scale.tolist(),
            "coef": model.coef_[0].tolist(), "intercept": float(model.intercept_[0]),
            "findings": int(len(y)), "right": int(y.sum())}


def probability(calibration: dict, finding: dict) -> float:
    z = (features(finding) - np.asarray(calibration["mean"])) / np.asarray(calibration["scale"])
    t = float(np.dot(calibration["coef"], z) + calibration["intercept"])
    return 1.0 / (1.0 + math.exp(-t)) if t > -700 else 0.0


@lru_cache(maxsize=1)
def shipped_map() -> dict | None:
    """The map fitted on the tuning families (None if the package has none)."""
    return json.loads(MAP_FILE.read_text()) if MAP_FILE.exists() else None


def calibrated_confidence(finding: dict) -> float | None:
    calibration = shipped_map()
    return None if calibration is None else probability(calibration, finding)
