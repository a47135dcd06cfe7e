"""mpmpp's stiction test: a closed-loop Hammerstein fit from OP and PV.

The PV is modelled as y(t) = B(q)/A(q) f(u)(t) + disturbance, with f a candidate valve
nonlinearity (mpmpp's actuator model, cpp/include/mpmpp/actuator.hpp: Choudhury's or He's
stick-slip law with S, J; backlash; a positioner deadband; saturation) driven by the
controller output u. For every candidate the valve is simulated and an ARX predictor
A(q) y = B(q) f(u) + c + e is refitted by least squares, so each candidate carries its own
disturbance correction (the ARX 1/A noise model). Scoring a candidate with a noise model fitted
for the linear valve instead hides stiction: that model has already absorbed the limit cycle.
B(q) starts at lag 1: a PI controller moves the OP within the sample of the PV it reads, so a
lag-0 term would fit the feedback, not the valve.

Candidates are ranked by blocked K-fold held-out one-step prediction error (the one-step
error is the Gaussian likelihood; multi-step criteria were weaker on the benchmark); the
linear valve is one candidate. The evidence is the held-out log-likelihood gain per sample of
the best hysteresis candidate (stick-slip, He, backlash) over the linear valve,
  g = 1/2 log(SSE_linear / SSE_candidate),
and the confidence is a logistic calibration of g, P(stiction | g), fitted on the TUNING
families of studies/stiction_benchmark.py.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from math import exp

import numpy as np

from .._core import ActuatorNonlinearity, StictionLaw, actuator_positions

# ARX orders shared by every candidate (so the valve parameters are the only difference):
# y lags 1..N_Y carry the process poles and the disturbance colour, valve lags 1..N_U cover a
# dead time of up to N_U - 1 samples.
N_Y = 4
N_U = 6
N_FOLDS = 5

# Logistic calibration P(stiction | g) = 1 / (1 + exp(-CAL_SLOPE (g - CAL_GAIN_AT_HALF))),
# fitted on the TUNING families of studies/stiction_benchmark.py (which prints the fit).
CAL_SLOPE = 95.0
CAL_GAIN_AT_HALF = 0.0078

HYSTERESIS_KINDS = ("stick_slip", "he", "backlash", "deadband")


@dataclass
class Candidate:
    kind: str
    params: dict
    cv_sse: float


@dataclass
class HammersteinResult:
    verdict: bool            # a valve fault with memory (stiction, backlash, deadband)
    kind: str                # best candidate kind ("linear" when nothing beats the linear valve)
    params: dict             # its parameters in OP units (S, J for stick-slip kinds)
    gain_per_sample: float   # held-out log-likelihood gain of the best hysteresis candidate
    confidence: float        # calibrated P(stiction | gain)
    ranking: list = field(repr=False, default_factory=list)

    def size_text(self) -> str:
        return ", ".join(f"{k}={v:.3g}" for k, v in self.params.items())


def _lagged(y: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    start = max(N_Y, N_U)
    n = len(y)
    cols = [y[start - k:n - k] for k in range(1, N_Y + 1)]
    cols += [v[start - k:n - k] for k in range(1, N_U + 1)]
    cols.append(np.ones(n - start))
    return np.column_stack(cols), y[start:]


def _held_out_losses(phi: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Squared one-step errors of each row, predicted by the ARX fitted on the other folds."""
    n = len(target)
    edges = np.linspace(0, n, N_FOLDS + 1).astype(int)
    out = np.empty(n)
    for a, b in zip(edges[:-1], edges[1:]):
        keep = np.r_[0:a, b:n]
        theta, *_ = np.linalg.lstsq(phi[keep], target[keep], rcond=None)
        out[a:b] = (target[a:b] - phi[a:b] @ theta) ** 2
    return out


def _candidate_grid(u: np.ndarray) -> list[tuple[str, ActuatorNonlinearity, dict]]:
    """(kind, actuator, reported params) over sizes relative to the OP's spread."""
    spread = float(np.percentile(u, 97.5) - np.percentile(u, 2.5))
    spread = spread if spread > 0 else 1.0
    # a band the OP crosses within a sample or two cannot make the valve visibly stick, and
    # such candidates only add selection noise to the comparison with the linear valve
    floor = 2.0 * float(np.median(np.abs(np.diff(u))))
    sizes = spread * np.array([0.03, 0.06, 0.1, 0.15, 0.2, 0.3, 0.4, 0.55, 0.7, 0.85, 1.0])
    grid = []
    for s in sizes[sizes >= floor]:
        grid.append(("backlash", ActuatorNonlinearity(backlash=s), {"S": s, "J": 0.0}))
        for ratio in (0.25, 0.5, 0.75, 1.0):
            j = ratio * s
            grid.append(("stick_slip", ActuatorNonlinearity(stiction_s=s, stiction_j=j), {"S": s, "J": j}))
            grid.append(("he", ActuatorNonlinearity(stiction_law=StictionLaw.he, stiction_s=s, stiction_j=j),
                         {"S": s, "J": j}))
    widths = spread * np.array([0.02, 0.05, 0.1, 0.2])
    for d in widths[widths >= floor]:
        grid.append(("deadband", ActuatorNonlinearity(deadband=d), {"width": d}))
    for q in (0.5, 1.0, 2.5, 5.0, 10.0):
        lo, hi = np.percentile(u, q), np.percentile(u, 100 - q)
        grid.append(("saturation_high", ActuatorNonlinearity(max=float(hi)), {"upper": float(hi)}))
        grid.append(("saturation_low", ActuatorNonlinearity(min=float(lo)), {"lower": float(lo)}))
    return grid


def calibrated_confidence(gain: float) -> float:
    z = CAL_SLOPE * (gain - CAL_GAIN_AT_HALF)
    return 1.0 / (1.0 + exp(-z)) if z > -700 else 0.0


def fit_valve(op, pv) -> HammersteinResult:
    """Rank the valve candidates for one loop record (OP and PV, equal length, finite)."""
    u = np.asarray(op, dtype=float)
    y = np.asarray(pv, dtype=float)
    if u.shape != y.shape or u.ndim != 1:
        raise ValueError("OP and PV must be 1-D and of equal length")
    if len(u) < 100:
        raise ValueError(f"too short: {len(u)} rows; the valve fit needs at least 100")
    if not (np.isfinite(u).all() and np.isfinite(y).all()):
        raise ValueError("OP and PV must not contain missing or infinite values")
    if np.ptp(u) == 0 or np.ptp(y) == 0:
        raise ValueError("OP or PV is constant: the record does not excite the valve")
    scale = np.std(y)
    y_s = (y - y.mean()) / scale

    def evaluate(kind, actuator, params):
        # the valve is taken at rest at the first OP (what it did before the record is unknown)
        v = actuator_positions(u, actuator, u[0])
        phi, target = _lagged(y_s, v)
        return Candidate(kind, params, float(_held_out_losses(phi, target).sum()))

    linear = evaluate("linear", ActuatorNonlinearity(), {})
    ranking = [linear] + [evaluate(*c) for c in _candidate_grid(u)]
    ranking.sort(key=lambda c: c.cv_sse)
    best = next(c for c in ranking if c.kind != "linear")
    hysteresis = next(c for c in ranking if c.kind in HYSTERESIS_KINDS)
    gain = 0.5 * np.log(linear.cv_sse / hysteresis.cv_sse)
    confidence = calibrated_confidence(gain)
    # a static nonlinearity (saturation) that explains the data better wins
    verdict = bool(confidence > 0.5 and best.kind in HYSTERESIS_KINDS)
    best_gain = 0.5 * np.log(linear.cv_sse / best.cv_sse)
    nonlinear = calibrated_confidence(best_gain) > 0.5
    return HammersteinResult(
        verdict=verdict,
        kind=best.kind if nonlinear else "linear",
        params=best.params if nonlinear else {},
        gain_per_sample=float(gain),
        confidence=float(confidence),
        ranking=ranking,
    )
