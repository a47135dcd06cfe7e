"""Actuator candidates: a valve nonlinearity that appears on an input at some onset (stick-slip,
backlash, deadband or saturation), seen by every channel from that input. (A sticking valve
present throughout a single loop's record is judged by the closed-loop Hammerstein fit,
``valve``.)

The plant sees f(u) = u + (f(u) - u): the candidate adds G (f(u) - u) to the nominal G u with
no free scale (the channel itself is unchanged). A free scale would let a very wide backlash
(f(u) nearly constant, f(u) - u ~ -u) pose as a plain gain change. Each candidate is scored
with the output's own noise correction and with the AR correction refitted together with it
(``refitted_noise``), and keeps the better: the correction fitted to the nominal residual has
already absorbed a limit cycle or the sticking phases, and in its domain every such candidate
would look worse.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..signals import Signals, valve_positions
from .errors import held_out_error
from .shapes import first_lag
from .laguerre import channel_basis
from .refitted_noise import OnsetGains, RefittedNoise
from .result import Finding, ModelChange
from .scoring import confidence
from .whitening import OutputResidual

WIDTHS = 2.0 ** (np.arange(-3, 13) / 3.0)  # times the median absolute input move: 0.5 to 16
SLIP_RATIO = 0.5                           # stick-slip J / S
WIDTH_BISECTIONS = 4                        # the width grid's ratio halved to 2^(1/48), 1.5 %
_HYSTERESIS = {"backlash": lambda w: {"kind": "backlash", "S": float(w)},
               "deadband": lambda w: {"kind": "deadband", "width": float(w)},
               "stick_slip": lambda w: {"kind": "stick_slip", "S": float(w), "J": SLIP_RATIO * float(w)}}
# saturation limits at these quantiles of the input; each side alone, then the other side added
LIMIT_QUANTILES = np.linspace(0.05, 0.95, 10)
LIMIT_BISECTIONS = 5                        # halvings of the grid's widest gap
PARAMS = 2 + 1 + 1   # kind and size, onset, noise correction (nominal or refitted)
# Rows x channels searched by default: a day of a 3x3 process at 5 s (~2.5 s CPU); longer
# records skip the search unless asked (diagnose's cost stays linear and within its budget).
SEARCH_WORK = 160_000


@dataclass
class ActuatorCandidate:
    """One valve block (the model file's actuator form, absolute input units) and its fit under
    the noise correction that fits it best: per training fold k, the in-fold statistic at the
    onset chosen on fold k (``fit[k]``) and the other fold's held-out statistic there
    (``held[k]``, per driven output)."""

    block: dict
    correction: str                # "model" (the output's nominal correction) or "refitted"
    onset: int                     # chosen on both folds together
    fit: np.ndarray                # (2,)
    held: np.ndarray               # (2, outputs)

    @property
    def kind(self) -> str:
        return self.block["kind"]


def _in_fold(k):
    """Search objective of training fold k (None: both folds, the block that is reported)."""
    return (lambda c: c.fit.sum()) if k is None else (lambda c: c.fit[k])


class ActuatorSearch:
    """The actuator candidates of one input, scored on the outputs its channels drive.

    Kind, size and onset are chosen on each fold's in-fold statistic and scored on the other
    fold (cross-validation: the held-out statistic of the chosen candidate carries no
    selection over the ~80 candidates); the reported block is the one chosen on both folds."""

    def __init__(self, outputs: list[OutputResidual], sig: Signals, j: int, onsets: np.ndarray, window: int):
        self.sig, self.j, self.onsets = sig, j, onsets
        self.op = sig.u[:, j] + sig.operating_point[sig.inputs[j]]
        self.driven = [out for out in outputs if out.row[j] is not None]
        self.refitted = [RefittedNoise(_one_step_error(out), out.fold, onsets) for out in self.driven]
        self.corrections = {"model": lambda i, out, d: model_correction_gains(out, d, self.onsets),
                            "refitted": lambda i, out, d: self.refitted[i].gains(out.noise.inverse().filter(d))}
        moves = np.abs(np.diff(self.op[np.isfinite(self.op)]))
        self.scale = float(np.median(moves[moves > 0])) if np.any(moves > 0) else 0.0   # median move
        self._cache: dict = {}
        # the input's median over the segment before each onset (throughout when there is none):
        # a saturation sets in on an input that worked inside its band, so the band holds it
        finite = np.isfinite(self.op)

        def median_before(k):
            before = slice(max(k - window, 0), k)
            return np.median(self.op[before][finite[before]]) if finite[before].any() else np.median(self.op[finite])

        self.median_before = np.array([median_before(k) for k in onsets])

    def evaluate(self, block: dict) -> ActuatorCandidate:
        """The candidate under the better of two noise corrections: the nominal one (the
        output's step + ramp disturbances fitted beside), and one refitted with the candidate.
        The first suits slow effects (a saturated input wandering off, which a refitted AR
        would difference away in the nominal residual too), the second effects the nominal
        correction has absorbed (a limit cycle). One onset for all the input's outputs."""
        key = tuple(sorted(block.items()))
        if key in self._cache:
            return self._cache[key]
        position = valve_positions(self.sig, self.j, block)
        moved = np.nan_to_num(position - self.op)
        responses = [out.channel_response(out.row[self.j], moved) for out in self.driven]
        allowed = np.ones(len(self.onsets), bool)
        if block["kind"] == "saturation":
            allowed = (block["lower"] <= self.median_before) & (self.median_before <= block["upper"])
        best = None
        for correction, domain in self.corrections.items():
            gains = [domain(i, out, d) for i, (out, d) in enumerate(zip(self.driven, responses))]
            in_fold = np.where(allowed[:, None], sum(g.in_fold for g in gains), -np.inf)
            picks = np.argmax(in_fold, axis=0)                    # per training fold
            cand = ActuatorCandidate(block, correction, int(self.onsets[np.argmax(in_fold.sum(axis=1))]),
                                     in_fold[picks, [0, 1]],
                                     np.array([[g.held_out[picks[k], k] for g in gains] for k in (0, 1)]))
            if best is None or cand.fit.sum() > best.fit.sum():
                best = cand
        self._cache[key] = best
        return best

    def best(self, k: int | None) -> ActuatorCandidate:
        """The best candidate on training fold k's in-fold statistic (both folds: None)."""
        objective = _in_fold(k)
        return max(self.best_hysteresis(objective), self.best_saturation(objective), key=objective)

    def best_hysteresis(self, objective) -> ActuatorCandidate:
        """The best kind and size: per kind, the best width on a grid of thirds of an octave of
        the median input move, refined by halving the grid's ratio WIDTH_BISECTIONS times. A
        deadband or stick-slip even a few per cent off its width predicts its jumps at the wrong
        samples and explains little (tuning mpc_2x2 seed 1, a deadband of 0.454: in-fold
        statistic 1122 at its width, 307 at 1.02x, the grid's nearest point)."""
        best = []
        for kind in _HYSTERESIS:
            width, cand = max(((w, self.evaluate(_HYSTERESIS[kind](w))) for w in self.scale * WIDTHS),
                              key=lambda wc: objective(wc[1]))
            ratio = WIDTHS[1] / WIDTHS[0]
            for _ in range(WIDTH_BISECTIONS):
                ratio = math.sqrt(ratio)
                for tried in (width / ratio, width * ratio):
                    other = self.evaluate(_HYSTERESIS[kind](tried))
                    if objective(other) > objective(cand):
                        width, cand = tried, other
            best.append(cand)
        return max(best, key=objective)

    def best_saturation(self, objective) -> ActuatorCandidate:
        """Upper limits alone, lower limits alone, then the best of them with the other side;
        each limit on a quantile grid of the input, refined by halving the quantile step. The
        band is at least the smallest hysteresis width wide: a narrower one is a valve that no
        longer moves, a dead channel (a gain change), not a limit the input runs into."""
        op = self.op[np.isfinite(self.op)]
        ends = {"lower": float(op.min()), "upper": float(op.max())}

        def best_limit(block, side):
            other = block["upper"] if side == "lower" else block["lower"]

            def tried(level):
                band = other - level if side == "lower" else level - other
                return self.evaluate({**block, side: float(level)}) if band >= WIDTHS[0] * self.scale else None

            levels = np.quantile(op, LIMIT_QUANTILES)
            grid = [(c, level) for level in levels if (c := tried(level)) is not None]
            if not grid:
                return None
            best, level = max(grid, key=lambda cl: objective(cl[0]))
            # refined by bisection (a limit a little off moves the samples where the input
            # leaves the band), to a 32nd of the grid's widest gap or a quarter median move
            step = float(np.max(np.diff(levels)))
            for _ in range(LIMIT_BISECTIONS):
                if step <= 0.25 * self.scale:
                    break
                step /= 2
                for level_try in (level - step, level + step):
                    cand = tried(level_try)
                    if cand is not None and objective(cand) > objective(best):
                        best, level = cand, level_try
            return best

        start = {"kind": "saturation", **ends}
        one = max((best_limit(start, side) for side in ("lower", "upper")), key=objective)
        other = "lower" if one.block["lower"] == ends["lower"] else "upper"
        two = best_limit(one.block, other)
        return two if two is not None and objective(two) > objective(one) else one


def actuator_findings(outputs: list[OutputResidual], sig: Signals, first_onset: int, min_segment: int,
                      step: int, logn: float, min_effect: float, skip=frozenset(),
                      judged_throughout=frozenset(), enabled: bool | None = None) -> tuple[list[Finding], list[str], dict]:
    """Per input (except those in ``skip``), the best actuator candidate when it passes the
    held-out tests, notes, and the penalised held-out score of each searched input's best
    candidate whether it passed or not (the rival a linear finding's confidence weighs). For
    inputs in ``judged_throughout`` (single loops, whose valve the Hammerstein fit judged over
    the whole record) only a nonlinearity that set in during the record is reported. ``enabled``: None searches when the record's rows times the
    channels searched stay within SEARCH_WORK (the cost of the ~80 candidates grows with both),
    True always, False never."""
    n = len(sig.time_s)
    inputs = [j for j, name in enumerate(sig.inputs) if name not in skip]
    channels = sum(out.row[j] is not None for out in outputs for j in inputs)
    if enabled is False or not channels:
        return [], [], {}
    if enabled is None and n * channels > SEARCH_WORK:
        return [], [f"actuator nonlinearities that set in during the record not searched: {n} rows x {channels} "
                    f"channels exceed {SEARCH_WORK} (cost); pass actuator_search=True (--actuator-search) to search"], {}
    # the process candidates' onset grid: a coarser one cost the saturation its fit on tuning
    # runs (mpc_siso seed 13 read as a gain of 0.01 at 6 min, kept at 2 min and finer)
    onsets = np.unique(np.r_[first_onset, np.arange(first_onset + min_segment, n - min_segment + 1, step)])
    found, scores = [], {}
    for j in inputs:
        name = sig.inputs[j]
        search = ActuatorSearch(outputs, sig, j, onsets, min_segment)
        if not search.driven or search.scale == 0.0:
            continue
        # per output: the held-out statistic of the candidates chosen on fold 0 and on fold 1
        heldout_per_output = search.best(0).held[0] + search.best(1).held[1]
        heldout = float(heldout_per_output.sum())
        score = scores[name] = heldout - 0.5 * PARAMS * logn
        best = search.best(None)
        if score <= 0.0 or (name in judged_throughout and best.onset <= first_onset):
            continue
        n_after = sum(out.weight[best.onset:].sum() for out in search.driven)
        if heldout < min_effect * n_after:
            continue
        # a nonlinearity must beat any linear change of the input's channels from its onset
        # (a backlash delays small moves: a delay change would otherwise pass for one)
        if heldout <= sum(linear_change_statistic(out, j, best.onset, best.correction) for out in search.driven):
            continue
        k_top = int(np.argmax(heldout_per_output))
        top = search.driven[k_top]
        changes = [ModelChange(output=out.name, input=name, actuator=best.block) for out in search.driven]
        err = held_out_error(top, best.onset, changes[k_top])
        if not err.improved:
            continue
        onset_s = float(sig.time_s[best.onset])
        found.append(Finding(
            id="", effect="input_nonlinearity", output=top.name, input=name, onset_s=onset_s,
            confidence=confidence(heldout, PARAMS),
            estimate={"kind": best.kind, "units": "input", "actuator": best.block, "noise_correction": best.correction,
                      **{k: v for k, v in best.block.items() if k != "kind"}},
            error_before=err.before, error_after=err.after,
            explanation=(f"actuator {name} behaves like {_describe(best.block)}"
                         + (f" since t={onset_s / 3600:.1f} h" if best.onset > 0 else "")),
            score=score, change=changes[k_top],
            extra_changes=[c for k, c in enumerate(changes) if k != k_top],
            outputs_driven=tuple(out.name for out in search.driven)))
    return found, [], scores


def model_correction_gains(out: OutputResidual, response: np.ndarray, onsets: np.ndarray) -> OnsetGains:
    """Drop of the whitened squared error from each onset on, per fold, for the output-error
    term ``response`` whitened with the output's own correction (nominal AR, beside its level
    and steps + ramps): the statistic every process candidate is scored with."""
    project = out.nuisance.project if out.nuisance is not None else (lambda x: x)
    r = project(out.r)
    w = project(out.whiten(response))
    drop = out.weight * (r**2 - (r - w) ** 2)
    suffix = np.column_stack([np.cumsum((drop * f)[::-1])[::-1][onsets] for f in out.fold])
    return OnsetGains(onsets, suffix, suffix[:, ::-1])


def linear_change_statistic(out: OutputResidual, j: int, onset: int, correction: str) -> float:
    """Held-out statistic of the best linear change of channel out <- input j from ``onset``,
    under the noise correction ``correction``: a Laguerre basis (process_error's, on the
    output's slowest pole) of the input delayed to a few samples before the channel's first
    lag, its coefficients fitted on each fold and scored on the other (a gain, time-constant
    or dead-time change, or a mix, lies in its span)."""
    responses = channel_basis(out.sig, out.i, j, first_lag(out.row[j]))
    after = np.arange(len(responses)) >= onset
    basis = np.where(after[:, None], np.nan_to_num(responses), 0.0)
    at = np.array([onset])
    hinv = out.noise.inverse()
    if correction == "refitted":
        e = _one_step_error(out)
        regressors = np.column_stack([hinv.filter(c) for c in basis.T])
        target, noise = e, RefittedNoise(e, out.fold, at)
    else:
        project = out.nuisance.project if out.nuisance is not None else (lambda x: x)
        regressors = np.column_stack([project(out.whiten(c)) for c in basis.T])
        target = project(out.r)
    total = 0.0
    for k in (0, 1):
        rows = (out.fold[k] > 0) & after
        if rows.sum() <= basis.shape[1]:
            continue
        response = basis @ np.linalg.lstsq(regressors[rows], target[rows], rcond=None)[0]
        gains = noise.gains(hinv.filter(response)) if correction == "refitted" else model_correction_gains(out, response, at)
        total += float(gains.held_out[0, k])
    return total


def rival_score(rival: Finding, nl: Finding, outputs: list[OutputResidual]) -> float:
    """The score of a linear stand-in ``rival`` for the actuator finding ``nl`` under the noise
    correction ``nl`` was scored with, so the two compare on one likelihood. Under the model's
    correction that is the rival's own score; under a refitted one the held-out statistic, with
    the AR refitted, of the rival's channel change from its onset, or of a drift's step + ramp
    from its onset (amplitudes by least squares on all rows; no penalty: the comparison leans
    to the linear explanation)."""
    if nl.estimate.get("noise_correction") != "refitted":
        return rival.score
    out = next(o for o in outputs if o.name == rival.output)
    onset = out.sig.seconds_to_index(rival.onset_s)
    hinv = out.noise.inverse()
    e = _one_step_error(out)
    if rival.effect == "output_drift":
        t = np.arange(len(e), dtype=float)
        columns = np.column_stack([hinv.filter(np.where(t >= onset, d, 0.0)) for d in (np.ones_like(t), t - onset)])
        rows = (out.weight > 0) & (t >= onset)
        psi = columns @ np.linalg.lstsq(columns[rows], e[rows], rcond=None)[0]
    elif rival.change is not None and rival.change.channel is not None:
        j = out.sig.inputs.index(rival.input)
        u = np.nan_to_num(out.sig.u[:, j])
        psi = hinv.filter(out.channel_response(rival.change.channel, u) - out.channel_response(out.row[j], u))
    else:
        return rival.score
    return float(RefittedNoise(e, out.fold, np.array([onset])).gains(psi).held_out.sum())


def _one_step_error(out: OutputResidual) -> np.ndarray:
    """The output's one-step error less its level and its step + ramp disturbances (fitted on
    the nominal error): left in, a stuck-valve candidate would explain the controller's
    compensation of a ramp (switching off the input that cancels it), the closed-loop
    confounding the process candidates avoid by fitting the disturbances beside them."""
    e = np.nan_to_num(out.free)
    return e - np.sum(e * out.weight) / out.weight.sum()


def _describe(block: dict) -> str:
    kind = block["kind"]
    if kind == "stick_slip":
        return f"a sticking valve (stick-slip, S = {block['S']:.3g}, J = {block['J']:.3g} input units)"
    if kind == "backlash":
        return f"a backlash of {block['S']:.3g} input units (small reversals do not reach the process)"
    if kind == "deadband":
        return f"a deadband of {block['width']:.3g} input units (small moves do not reach the process)"
    return f"a saturation at [{block['lower']:.4g}, {block['upper']:.4g}] (moves beyond it do not reach the process)"
