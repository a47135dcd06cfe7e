"""Actuator candidates for an input that drives several outputs (an MPC's MV): a backlash or
stick-slip on the input, seen by every channel from it. (A single loop's valve is judged by
the closed-loop Hammerstein fit, ``valve``.)

The plant sees f(u) = u + (f(u) - u): the candidate adds G (f(u) - u) to the nominal G u with
no free scale (the channel itself is unchanged). A free scale would let a very wide backlash
(f(u) nearly constant, f(u) - u ~ -u) pose as a plain gain change.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import _core
from .._core import TransferFunction
from ..signals import Signals
from .errors import held_out_error
from .result import Finding, ModelChange
from .scoring import confidence
from .whitening import OutputResidual

BACKLASH_WIDTHS = (0.5, 1.0, 2.0, 4.0, 8.0, 16.0)   # times the median absolute MV move
ACTUATOR_KINDS = ("backlash", "stick_slip")
PARAMS = 2 + 1   # kind and width, onset


@dataclass
class ActuatorResponse:
    """One output driven by the actuator: its nominal channel, best onset and held-out gain."""

    output: OutputResidual = field(repr=False)
    nominal: TransferFunction
    onset: int
    heldout: float


@dataclass
class ActuatorCandidate:
    kind: str                     # one of ACTUATOR_KINDS
    width: float                  # input units
    moved: np.ndarray = field(repr=False)   # f(u), deviation from its mean
    responses: list[ActuatorResponse] = field(default_factory=list)

    @property
    def heldout(self) -> float:
        return sum(r.heldout for r in self.responses)

    def score(self, logn: float) -> float:
        return self.heldout - 0.5 * PARAMS * logn


def _response(out: OutputResidual, g: TransferFunction, u: np.ndarray, moved: np.ndarray,
              first_onset: int, min_segment: int, step: int) -> ActuatorResponse:
    """Best onset of G (f(u) - u) in output ``out`` on all data, and its two-fold held-out gain."""
    # beside the output's level and step + ramp disturbances, as the channel candidates
    project = out.nuisance.project if out.nuisance is not None else (lambda x: x)
    r = project(out.r)
    psi = project(out.whiten(out.channel_response(g, moved - u)))
    drop = out.weight * (r**2 - (r - psi) ** 2)
    onsets = np.r_[first_onset, np.arange(first_onset + min_segment, len(u) - min_segment + 1, step)]

    def best_onset(w):
        suffix = np.cumsum((drop * w)[::-1])[::-1]
        return int(onsets[np.argmax(suffix[onsets])])

    heldout = 0.0
    for k in (0, 1):
        heldout += float(np.sum((drop * out.fold[1 - k])[best_onset(out.fold[k]):]))
    return ActuatorResponse(out, g, best_onset(np.ones(len(u))), heldout)


def _candidate(outputs: list[OutputResidual], j: int, u: np.ndarray, kind: str, width: float,
               first_onset: int, min_segment: int, step: int) -> ActuatorCandidate:
    moved = getattr(_core, kind)(u, width)
    moved = moved - np.mean(moved)
    cand = ActuatorCandidate(kind, width, moved)
    for out in outputs:
        g = out.row[j]
        if g is not None:
            cand.responses.append(_response(out, g, u, moved, first_onset, min_segment, step))
    return cand


def actuator_findings(outputs: list[OutputResidual], sig: Signals, first_onset: int, min_segment: int,
                      step: int, logn: float, min_effect: float, skip=frozenset()) -> list[Finding]:
    """Per input (except those in ``skip``: single loops, judged by ``valve``), the best
    actuator candidate when it passes the held-out tests."""
    found = []
    for j, name in enumerate(sig.inputs):
        if name in skip:
            continue
        u = np.nan_to_num(sig.u[:, j])
        moves = np.abs(np.diff(u))
        scale = float(np.median(moves[moves > 0])) if np.any(moves > 0) else 0.0
        if scale == 0.0:
            continue
        best = None
        for kind in ACTUATOR_KINDS:
            for factor in BACKLASH_WIDTHS:
                cand = _candidate(outputs, j, u, kind, factor * scale, first_onset, min_segment, step)
                if cand.responses and (best is None or cand.score(logn) > best.score(logn)):
                    best = cand
        if best is None or best.score(logn) <= 0.0:
            continue
        n_after = sum(r.output.weight[r.onset:].sum() for r in best.responses)
        if best.heldout < min_effect * n_after:
            continue
        top = max(best.responses, key=lambda r: r.heldout)
        # The fixed model format has no actuator block: update applies the describing-function
        # gain, the linear channel scale that best matches the actuator's response.
        ratio = _describing_gain(u, best.moved)
        changes = [ModelChange(output=r.output.name, input=name,
                               channel=TransferFunction(np.asarray(r.nominal.num) * ratio, r.nominal.den,
                                                        r.nominal.delay))
                   for r in best.responses]
        primary = changes[best.responses.index(top)]
        err = held_out_error(top.output, top.onset, primary)
        if not err.improved:
            continue
        onset_s = float(sig.time_s[top.onset])
        found.append(Finding(
            id="", effect="input_nonlinearity", output=top.output.name, input=name, onset_s=onset_s,
            confidence=confidence(best.heldout, PARAMS),
            estimate={"kind": best.kind, "width": best.width, "ci95": [best.width / 2, best.width * 2],
                      "equivalent_gain_ratio": ratio},
            error_before=err.before, error_after=err.after,
            explanation=(f"actuator {name} behaves like a {best.kind.replace('_', '-')} of about "
                         f"{best.width:.3g} units (small moves do not reach the process)"
                         + (f" since t={onset_s / 3600:.1f} h" if top.onset > 0 else "")),
            score=best.score(logn), change=primary,
            extra_changes=[c for c in changes if c is not primary],
            outputs_driven=tuple(r.output.name for r in best.responses)))
    return found


def _describing_gain(u: np.ndarray, moved: np.ndarray) -> float:
    """Least-squares scale k with k u ~ f(u) (both as deviations from their means): the linear
    channel gain ratio that best reproduces the actuator (what the fixed model format can hold)."""
    x = u - u.mean()
    target = moved - moved.mean()
    return float(x @ target / (x @ x)) if x @ x > 0 else 1.0
