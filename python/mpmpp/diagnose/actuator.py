"""Actuator candidates: a valve nonlinearity that appears on an input at some onset (stick-slip,
backlash, deadband or saturation), seen by every channel from that input. (A sticking valve
present throughout a single loop's record is judged by the closed-loop Hammerstein fit,
``valve``.)

The plant sees f(u) = u + (f(u) - u): the candidate adds G (f(u) - u) to the nominal G u with
no free scale (the channel itself is unchanged). A free scale would let a very wide backlash
(f(u) nearly constant, f(u) - u ~ -u) pose as a plain gain change. Each candidate is scored
with the output's AR noise correction refitted together with it (``refitted_noise``): the
correction fitted to the nominal residual has already absorbed a limit cycle or the sticking
phases, and every candidate would look worse in its domain.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..signals import Signals, per_segment
from ..stiction.valve import valve_position
from .errors import held_out_error
from .refitted_noise import OnsetGains, RefittedNoise
from .result import Finding, ModelChange
from .scoring import confidence
from .whitening import OutputResidual

WIDTHS = 2.0 ** (np.arange(-3, 13) / 3.0)  # times the median absolute input move: 0.5 to 16
SLIP_RATIO = 0.5                           # stick-slip J / S
# saturation limits at these quantiles of the input; each side alone, then the other side added
LIMIT_QUANTILES = np.linspace(0.05, 0.95, 10)
PARAMS = 2 + 1 + 1   # kind and size, onset, noise correction (nominal or refitted)


@dataclass
class ActuatorCandidate:
    """One valve block (the model file's actuator form, absolute input units) and its fit."""

    block: dict
    onset: int = 0
    heldout: float = -np.inf
    heldout_per_output: list = field(default_factory=list)

    @property
    def kind(self) -> str:
        return self.block["kind"]

    def score(self, logn: float) -> float:
        return self.heldout - 0.5 * PARAMS * logn


class ActuatorSearch:
    """The actuator candidates of one input, scored on the outputs its channels drive."""

    def __init__(self, outputs: list[OutputResidual], sig: Signals, j: int, onsets: np.ndarray):
        self.sig, self.j, self.onsets = sig, j, onsets
        self.op = sig.u[:, j] + sig.operating_point[sig.inputs[j]]
        self.driven = [out for out in outputs if out.row[j] is not None]
        self.refitted = [RefittedNoise(out.free, out.fold, onsets) for out in self.driven]

    def evaluate(self, block: dict) -> ActuatorCandidate:
        """The candidate's onset (one for all its outputs: chosen on each fold's in-fold
        statistic, summed over the outputs) and its held-out statistic, under the better of two
        noise corrections: the nominal one (the output's step + ramp disturbances fitted
        beside), and one refitted with the candidate. The first suits slow effects (a
        saturated input wandering off, which a refitted AR would difference away in the
        nominal residual too), the second effects the nominal correction has absorbed (a
        limit cycle)."""
        position = per_segment(self.sig, lambda x: valve_position(block, x), self.op)
        moved = np.nan_to_num(position - self.op)
        best = None
        for domain in (self._nominal_gains, self._refitted_gains):
            gains = [domain(k, out, out.channel_response(out.row[self.j], moved)) for k, out in enumerate(self.driven)]
            in_fold = sum(g.in_fold for g in gains)
            picks = np.argmax(in_fold, axis=0)                    # per training fold
            per_output = [float(sum(g.held_out[picks[k], k] for k in (0, 1))) for g in gains]
            cand = ActuatorCandidate(block, int(self.onsets[np.argmax(in_fold.sum(axis=1))]), sum(per_output),
                                     per_output)
            if best is None or cand.heldout > best.heldout:
                best = cand
        return best

    def _refitted_gains(self, k: int, out: OutputResidual, response: np.ndarray) -> OnsetGains:
        """``response``: the candidate's G (f(u) - u) in output ``out``."""
        return self.refitted[k].gains(out.noise.inverse().filter(response))

    def _nominal_gains(self, k: int, out: OutputResidual, response: np.ndarray) -> OnsetGains:
        """Drop of the whitened squared error (nominal AR, beside the output's level and steps +
        ramps) from each onset on, per fold."""
        project = out.nuisance.project if out.nuisance is not None else (lambda x: x)
        r = project(out.r)
        w = project(out.whiten(response))
        drop = out.weight * (r**2 - (r - w) ** 2)
        suffix = [np.cumsum((drop * f)[::-1])[::-1][self.onsets] for f in out.fold]
        return OnsetGains(self.onsets, np.column_stack(suffix), np.column_stack(suffix[::-1]))

    def best_hysteresis(self, logn: float) -> ActuatorCandidate | None:
        """The best kind and size on a grid of thirds of an octave of the median input move
        (fine: a deadband or stick-slip a quarter too wide predicts its jumps at the wrong
        samples and explains nothing)."""
        moves = np.abs(np.diff(self.op[np.isfinite(self.op)]))
        scale = float(np.median(moves[moves > 0])) if np.any(moves > 0) else 0.0
        if scale == 0.0:
            return None
        blocks = []
        for w in scale * WIDTHS:
            blocks += [{"kind": "backlash", "S": w}, {"kind": "deadband", "width": w},
                       {"kind": "stick_slip", "S": w, "J": SLIP_RATIO * w}]
        return max((self.evaluate(b) for b in blocks), key=lambda c: c.score(logn))

    def best_saturation(self, logn: float) -> ActuatorCandidate:
        """Upper limits alone, lower limits alone, then the best of them with the other side;
        each limit on a quantile grid of the input, refined by halving the quantile step."""
        op = self.op[np.isfinite(self.op)]
        ends = {"lower": float(op.min()), "upper": float(op.max())}

        def best_limit(block, side):
            other = block["upper"] if side == "lower" else block["lower"]

            def valid(level):   # on its side of the other limit
                return level < other if side == "lower" else level > other

            def tried(q):
                level = float(np.quantile(op, min(max(q, 0.0), 1.0)))
                return self.evaluate({**block, side: level}) if valid(level) else None

            grid = [(c, q) for q in LIMIT_QUANTILES if (c := tried(q)) is not None]
            if not grid:
                return None
            best, q = max(grid, key=lambda cq: cq[0].score(logn))
            dq = LIMIT_QUANTILES[1] - LIMIT_QUANTILES[0]
            for _ in range(3):
                dq /= 2
                for q_try in (q - dq, q + dq):
                    cand = tried(q_try)
                    if cand is not None and cand.score(logn) > best.score(logn):
                        best, q = cand, q_try
            return best

        start = {"kind": "saturation", **ends}
        one = max((best_limit(start, side) for side in ("lower", "upper")), key=lambda c: c.score(logn))
        other = "lower" if one.block["lower"] == ends["lower"] else "upper"
        two = best_limit(one.block, other)
        return two if two is not None and two.score(logn) > one.score(logn) else one


def actuator_findings(outputs: list[OutputResidual], sig: Signals, first_onset: int, min_segment: int,
                      step: int, logn: float, min_effect: float, skip=frozenset()) -> list[Finding]:
    """Per input (except those in ``skip``), the best actuator candidate when it passes the
    held-out tests."""
    n = len(sig.time_s)
    onsets = np.unique(np.r_[first_onset, np.arange(first_onset + min_segment, n - min_segment + 1, step)])
    found = []
    for j, name in enumerate(sig.inputs):
        if name in skip:
            continue
        search = ActuatorSearch(outputs, sig, j, onsets)
        if not search.driven:
            continue
        hysteresis = search.best_hysteresis(logn)
        if hysteresis is None:
            continue
        best = max(hysteresis, search.best_saturation(logn), key=lambda c: c.score(logn))
        if best.score(logn) <= 0.0:
            continue
        n_after = sum(out.weight[best.onset:].sum() for out in search.driven)
        if best.heldout < min_effect * n_after:
            continue
        k_top = int(np.argmax(best.heldout_per_output))
        top = search.driven[k_top]
        changes = [ModelChange(output=out.name, input=name, actuator=best.block) for out in search.driven]
        err = held_out_error(top, best.onset, changes[k_top])
        if not err.improved:
            continue
        onset_s = float(sig.time_s[best.onset])
        found.append(Finding(
            id="", effect="input_nonlinearity", output=top.name, input=name, onset_s=onset_s,
            confidence=confidence(best.heldout, PARAMS),
            estimate={"kind": best.kind, "units": "input", "actuator": best.block,
                      **{k: v for k, v in best.block.items() if k != "kind"}},
            error_before=err.before, error_after=err.after,
            explanation=(f"actuator {name} behaves like {_describe(best.block)}"
                         + (f" since t={onset_s / 3600:.1f} h" if best.onset > 0 else "")),
            score=best.score(logn), change=changes[k_top],
            extra_changes=[c for k, c in enumerate(changes) if k != k_top],
            outputs_driven=tuple(out.name for out in search.driven)))
    return found


def _describe(block: dict) -> str:
    kind = block["kind"]
    if kind == "stick_slip":
        return f"a sticking valve (stick-slip, S = {block['S']:.3g}, J = {block['J']:.3g} input units)"
    if kind == "backlash":
        return f"a backlash of {block['S']:.3g} input units (small reversals do not reach the process)"
    if kind == "deadband":
        return f"a deadband of {block['width']:.3g} input units (small moves do not reach the process)"
    return f"a saturation at [{block['lower']:.4g}, {block['upper']:.4g}] (moves beyond it do not reach the process)"
