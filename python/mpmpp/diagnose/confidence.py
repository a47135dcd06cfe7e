"""A finding's confidence: the probability that it is right, from the evidence it carries.

The held-out likelihood gain alone (its chi-square CDF, ``scoring.confidence``) is ~1 for every
finding on long closed-loop records, right or wrong. What tells a right finding from a wrong
one is how much evidence it has relative to the record, whether its update lowers the held-out
errors (a finding whose update barely lowers them is not a confident one), and how large the
input-explained part of the error is against the disturbance, how nearly the actuator search
explains the same record (for a gain, time-constant or dead-time finding: a gain is what an
unmodelled valve nonlinearity looks like to a linear fit; and whether it explains it as well),
and which effect it names (an output
drift is rarely anything else). A logistic
map of these features is fitted on the TUNING scenario families only (studies/calibrate_confidence.py writes
confidence_map.json); its reliability is reported on the held-out families
(studies/diagnosis_families.py, docs/diagnose.md).
"""
from __future__ import annotations

import json
import math
from functools import lru_cache
from pathlib import Path

import numpy as np

from .process import SCALED_CHANNEL_EFFECTS
from .result import EFFECTS

MAP_FILE = Path(__file__).with_name("confidence_map.json")
# A missing coupling and an unmodelled measured input are the same search (a new input channel).
_EFFECT_KIND = {"unmodeled_input": "missing_coupling"}
_KINDS = tuple(e for e in EFFECTS if e not in _EFFECT_KIND)
FEATURES = ("log_score", "one_step_fall", "process_fall", "process_share", "actuator_rival", "actuator_close") + tuple(
    f"effect_{k}" for k in _KINDS)
# actuator_rival above this: the actuator search explains the record about as well as the
# finding (tuning families PI seeds 0-9, MPC seeds 0-5: such gain, time-constant and dead-time
# findings were right 12 of 25 times, those between -0.5 and -0.1 30 of 35).
ACTUATOR_CLOSE = -0.1


def _ratio_fall(before, after) -> float:
    """1 - after / before, clipped to [-1, 1]; 0 when either is unknown."""
    if before is None or after is None or not (before > 0) or not math.isfinite(after):
        return 0.0
    return float(np.clip(1.0 - after / before, -1.0, 1.0))


def _actuator_rival(finding: dict) -> float:
    """For a gain, time-constant or dead-time finding: log(1 + the actuator search's score on
    its input) - log(1 + its own score), scores floored at 0. Near 0 or above, an actuator
    nonlinearity explains the record about as well (a sticking or dead-band valve looks like a
    lower gain to a linear fit); 0 too when the search did not run on that input (nothing rules
    the actuator out). 0 for other effects (their effect indicator absorbs the constant)."""
    if finding["effect"] not in SCALED_CHANNEL_EFFECTS:
        return 0.0
    rival = finding.get("actuator_score")
    if rival is None:
        return 0.0
    return math.log1p(max(float(rival), 0.0)) - math.log1p(max(float(finding.get("score", 0.0)), 0.0))


def _actuator_close(finding: dict) -> float:
    """1 where the actuator search on the finding's input scores about as well as the finding
    (``_actuator_rival`` above ACTUATOR_CLOSE), else 0. The rival enters the logistic map
    linearly, so on a long record the finding's own large score outweighed it: a valve pinned
    beyond its band and a gain cut to a quarter explain such a record equally, and which one
    is right is a coin toss whatever the score (a tie is not evidence for either)."""
    rival = finding.get("actuator_score")
    if finding["effect"] not in SCALED_CHANNEL_EFFECTS or rival is None:
        return 0.0
    return 1.0 if _actuator_rival(finding) > ACTUATOR_CLOSE else 0.0


def features(finding: dict) -> np.ndarray:
    """The evidence of one finding (``Finding.to_dict()`` plus its ``score`` and
    ``actuator_score``)."""
    pb, eb = finding.get("process_error_before"), finding.get("error_before")
    share = math.log(pb / eb) if pb and eb and pb > 0 and eb > 0 else math.log(1e-3)
    return np.array([
        math.log1p(max(float(finding.get("score", 0.0)), 0.0)),
        _ratio_fall(eb, finding.get("error_after")),
        _ratio_fall(pb, finding.get("process_error_after")),
        max(share, math.log(1e-3)),
        _actuator_rival(finding),
        _actuator_close(finding),
        *(1.0 if _EFFECT_KIND.get(finding["effect"], finding["effect"]) == k else 0.0 for k in _KINDS),
    ])


# The error falls a finding's update achieves may only raise its confidence: a finding whose
# update barely lowers the held-out errors is not a confident one, whatever the tuning
# families happen to show (a negative weight there is the fit chasing a few runs).
MONOTONE_FEATURES = ("one_step_fall", "process_fall")


def fit_map(findings: list[dict], labels: list[bool], regularisation: float = 1.0) -> dict:
    """Logistic regression of right/wrong on the standardised features, L2-penalised as
    scikit-learn's ``LogisticRegression(C=regularisation)``, with the weights of
    MONOTONE_FEATURES bounded below by 0 (L-BFGS-B)."""
    from scipy.optimize import minimize

    x = np.array([features(f) for f in findings])
    y = np.asarray(labels, dtype=int)
    if len(set(y)) < 2:
        raise ValueError("calibration needs right and wrong findings")
    mean, scale = x.mean(axis=0), x.std(axis=0)
    scale[scale == 0] = 1.0
    z = np.column_stack([(x - mean) / scale, np.ones(len(y))])
    sign = 2.0 * y - 1.0

    def loss(w):
        t = sign * (z @ w)
        p = 0.5 * (1.0 - np.tanh(0.5 * t))          # 1 / (1 + exp(t)), overflow-free
        value = np.sum(np.logaddexp(0.0, -t)) + 0.5 * np.dot(w[:-1], w[:-1]) / regularisation
        grad = -(sign * p) @ z
        grad[:-1] += w[:-1] / regularisation
        return value, grad

    bounds = [(0.0, None) if name in MONOTONE_FEATURES else (None, None) for name in FEATURES] + [(None, None)]
    fit = minimize(loss, np.zeros(z.shape[1]), jac=True, method="L-BFGS-B", bounds=bounds,
                   options={"gtol": 1e-10, "ftol": 1e-14, "maxiter": 10000})
    coef = np.where([b[0] == 0.0 for b in bounds[:-1]], np.maximum(fit.x[:-1], 0.0), fit.x[:-1])
    return {"features": list(FEATURES), "mean": mean.tolist(), "scale": scale.tolist(),
            "coef": coef.tolist(), "intercept": float(fit.x[-1]),
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
