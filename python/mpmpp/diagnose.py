"""Diagnosis: which physical effect is missing from the model, where and since when.

Method (docs/diagnose.md has the long form). Per output i, with v = y_i - G_i u the output
error of the nominal model and e = H_i^-1 v its one-step prediction error:

1. Residual statistics over time. A two-segment AR(5) split of e (``split_ar``) finds where
   the residual's level or colour changes. Each side gets its own AR correction A_s(q), so
   ``whiten(x) = A_s H^-1 x / sigma_s`` turns e into (nearly) white, unit-variance noise
   whatever the disturbance did. Whitening with a *re-estimated* noise model is what keeps the
   process fits consistent in closed loop when the disturbance changed (the direct method is
   biased when the noise model is wrong); the AR is fitted to e alone, not jointly with the
   inputs, so it cannot manufacture an input correlation.
2. Process candidates. Each replaces one channel, from an onset on, by theta * S(q) with a
   shape S: the model's channel (``gain``), the channel with a new time constant
   (``time_constant``) or delay (``delay``), a unit-gain first-order-plus-delay channel from an
   input the model says has none (``missing_coupling``) or from an extra data column
   (``unmodeled_input``), or the channel driven through an actuator backlash
   (``input_nonlinearity``, no free scale), or an additive ramp/step (``output_drift``).
   ``scan_onset`` gives the best onset and theta per shape (exact two-segment least squares),
   shapes are searched on grids.
3. Held-out scoring. The record is cut into 1 h blocks; shape, onset and theta are chosen on
   the even blocks and scored on the odd ones and vice versa. The score is the held-out drop
   of the whitened squared error (a likelihood-ratio statistic) minus log(N)/2 per parameter
   (theta, grid value, onset). A finding needs a positive score, a held-out drop of at least
   ``min_effect`` of the error variance, an effect present in both halves after its onset and
   a lower held-out error for the model ``update`` writes; findings are accepted greedily, the
   residual updated after each.
4. Noise candidates, on outputs without a process finding: ``noise_change`` (new noise model
   H / A_after, or an innovation-level change) and ``output_drift`` (a slow drift component
   H (1 - c q^-1) / (1 - rho q^-1) after the onset), scored the same way in the nominal
   model's one-step-error domain. A drift that wins in the process pool is written the same way.

error_before / error_after: RMS of the one-step prediction error of the affected output
(output units, signals as deviations from the record mean), on the held-out blocks after the
onset, with the nominal model and with the model that ``update`` writes (fitted on the other
blocks).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import _core
from ._core import TransferFunction
from .signals import Signals, extract, per_segment

EFFECTS = ("gain", "time_constant", "delay", "missing_coupling", "unmodeled_input",
           "noise_change", "output_drift", "input_nonlinearity")
PROCESS_EFFECTS = ("gain", "time_constant", "delay", "missing_coupling", "unmodeled_input",
                   "input_nonlinearity")

AR_ORDER = 5                 # AR correction of the noise model (residual whitening)
SETTLE = 60                  # samples left out after the start of each filtered segment
TIME_CONSTANT_FACTORS = (0.33, 0.5, 0.67, 0.8, 1.25, 1.5, 2.0, 3.0)
DELAY_RANGE = (-10, 15)      # new delay = model delay + this range (samples)
COUPLING_POLES = (0.0, 0.5, 0.8, 0.9, 0.95, 0.98)
# Delay >= 1: in closed loop u(t) may already react to y(t), a lag-0 channel would fit feedback.
COUPLING_DELAYS = range(1, 41)
DRIFT_POLES = (0.995, 0.998, 0.999, 0.9995)
DRIFT_ZEROS = (0.8, 0.9, 0.95, 0.98)
BACKLASH_WIDTHS = (0.5, 1.0, 2.0, 4.0, 8.0, 16.0)   # times the median absolute MV move
ACTUATOR_KINDS = ("backlash", "stick_slip")
DRIFT_GRID_S = 1800.0
DRIFT_COLUMN = "(drift)"
MAX_FINDINGS_PER_OUTPUT = 3


# --------------------------------------------------------------------------------------------
# Results


@dataclass
class ModelChange:
    """What ``update`` applies: a process channel (possibly from a new input column) set to
    ``channel`` and/or the output's noise model set to ``noise``; ``backlash`` for the record."""

    output: str
    input: str | None = None
    channel: TransferFunction | None = None
    noise: TransferFunction | None = None
    new_input: bool = False


@dataclass
class Finding:
    id: str
    effect: str
    output: str | None
    input: str | None
    onset_s: float
    confidence: float
    estimate: dict
    error_before: float
    error_after: float
    explanation: str
    score: float = field(repr=False, default=0.0)
    change: ModelChange | None = field(repr=False, default=None)

    def to_dict(self) -> dict:
        d = {"id": self.id, "effect": self.effect}
        if self.output is not None:
            d["output"] = self.output
        if self.input is not None:
            d["input"] = self.input
        d.update(onset_s=round(self.onset_s, 3), confidence=round(self.confidence, 4),
                 estimate={k: _rounded(v) for k, v in self.estimate.items()},
                 error_before=_rounded(self.error_before), error_after=_rounded(self.error_after),
                 explanation=self.explanation)
        return d


@dataclass
class DiagnoseResult:
    model: str
    train_end_s: float | None
    findings: list[Finding]
    metric: str = ("RMS of the one-step prediction error of the output (deviation units) on "
                   "held-out 1 h blocks after onset_s")
    # per output: time, nominal one-step error (for plots)
    time_s: np.ndarray = field(repr=False, default=None)
    residuals: dict = field(repr=False, default_factory=dict)

    def to_dict(self) -> dict:
        return {"findings": [f.to_dict() for f in self.findings]}

    def finding(self, finding_id: str) -> Finding:
        for f in self.findings:
            if f.id == finding_id:
                return f
        known = ", ".join(f.id for f in self.findings) or "none"
        raise ValueError(f"--apply: no finding '{finding_id}' (findings: {known})")

    def summary(self) -> str:
        if not self.findings:
            return f"diagnose: model '{self.model}' is consistent with the data (no finding)"
        lines = [f"diagnose: model '{self.model}', {len(self.findings)} finding(s), most likely first"]
        for f in self.findings:
            lines.append(f"  {f.id} [{f.effect}] {f.explanation} (confidence {f.confidence:.2f}; "
                         f"error {f.error_before:.4g} -> {f.error_after:.4g})")
        lines.append(f"  error = {self.metric}")
        return "\n".join(lines)

    def plot(self, out_dir, clock=None) -> list[Path]:
        """One figure per output; with the data's ``clock`` (mpmpp.clock.Clock) the time
        axis is the data's own (dates for calendar time)."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = []
        for name, e in self.residuals.items():
            fig, ax = plt.subplots(figsize=(11, 3.5))
            from .clock import time_axis

            def axis(t):
                return time_axis(clock, t, label="time [h]")

            t, xlabel = axis(self.time_s)
            ax.plot(t, e, lw=0.4, color="0.4", label="one-step error of the model")
            for f in self.findings:
                if f.output == name or (f.output is None and f.effect == "input_nonlinearity"):
                    onset = axis([f.onset_s])[0][0]
                    ax.axvline(onset, color="r", ls="--")
                    ax.text(onset, ax.get_ylim()[1] * 0.9, f" {f.id} {f.effect}", color="r")
            ax.set_xlabel(xlabel)
            ax.set_ylabel(name)
            ax.set_title(f"{name}: one-step prediction error and findings")
            fig.tight_layout()
            path = out / f"diagnose_{name}.png"
            fig.savefig(path, dpi=90)
            plt.close(fig)
            paths.append(path)
        return paths


# --------------------------------------------------------------------------------------------
# Per-output whitening and held-out blocks


class _Output:
    """Everything about one output that the candidate fits share."""

    def __init__(self, sig: Signals, i: int, min_segment: int, first_onset: int, block: int):
        self.sig, self.i, self.name = sig, i, sig.outputs[i]
        n = len(sig.time_s)
        self.row, self.noise = sig.rows[i], sig.noise[i]
        self.v = per_segment(sig, lambda yy, uu: _core.output_error(self.row, yy, uu), sig.y[:, i], sig.u)
        self.e = per_segment(sig, lambda vv: self.noise.inverse().filter(vv), self.v)
        base = np.zeros(n)
        for a, b in sig.segments:
            base[a + SETTLE:b] = 1.0
        self.weight = base
        e0 = np.nan_to_num(self.e)
        # The split looks for a change of the disturbance's level or colour. A slow drift
        # changes the AR fit too, and a split inside it lets each side's correction absorb a
        # different part of it; so the split is made on e with its best step + ramp removed
        # (the drift itself is a candidate of the process pool).
        _, _, trend = _trend_fit(e0, base > 0, self.noise.inverse(), first_onset, 4 * min_segment // 12)
        split = _core.split_ar((e0 - trend)[first_onset:], AR_ORDER, min_segment, max(min_segment // 60, 1))
        self.split = split
        self.split_onset = first_onset + split.onset if split.statistic > 0 else None
        # The split is kept when it beats its parameters (AR coefficients, variance, onset).
        self.split_significant = split.statistic > (AR_ORDER + 2) * math.log(n)
        cuts = [self.split_onset] if self.split_significant else []
        self.pieces = _pieces(sig.segments, cuts)
        self.ar = [_core.fit_ar(e0, AR_ORDER, a + SETTLE, b) for a, b in self.pieces]
        self.sigma = []
        for (a, b), poly in zip(self.pieces, self.ar):
            w = TransferFunction(poly, [1.0], 0).filter(e0[a:b])[SETTLE:]
            self.sigma.append(float(np.sqrt(np.mean(w**2))))
        self.r = self.whiten(np.nan_to_num(self.v))
        # Held-out blocks: even / odd blocks of `block` samples.
        parity = (np.arange(n) // block) % 2
        self.fold = [self.weight * (parity == 0), self.weight * (parity == 1)]
        self.n = int(self.weight.sum())

    def whiten(self, x: np.ndarray) -> np.ndarray:
        """A_s H^-1 x / sigma_s per piece (filters restart at every piece)."""
        out = np.zeros_like(x, dtype=float)
        hinv = self.noise.inverse()
        for (a, b), poly, s in zip(self.pieces, self.ar, self.sigma):
            out[a:b] = TransferFunction(poly, [1.0], 0).filter(hinv.filter(x[a:b])) / s
        return out

    def channel_response(self, g: TransferFunction, x: np.ndarray) -> np.ndarray:
        """g x per data segment (zero outside)."""
        return np.nan_to_num(per_segment(self.sig, g.filter, x))


def _pieces(segments, cuts):
    out = []
    for a, b in segments:
        inner = sorted(c for c in cuts if a + 2 * SETTLE < c < b - 2 * SETTLE)
        edges = [a, *inner, b]
        out += list(zip(edges[:-1], edges[1:]))
    return out


# --------------------------------------------------------------------------------------------
# Candidate shapes


@dataclass
class _Shape:
    """A candidate: channel (output <- column) replaced by theta * shape after an onset."""

    effect: str
    column: str
    kind: str                     # "input" or "extra"
    shape: TransferFunction       # theta = 1 means the shape itself
    nominal: TransferFunction | None
    label: float                  # the grid value (gain 1, time-constant factor, delay, pole)
    params: int                   # fitted parameters incl. the grid choice (onset counted later)
    drive: np.ndarray = field(repr=False, default=None)   # the column the channel filters


def _first_order_with_time_constant(g: TransferFunction, factor: float) -> TransferFunction | None:
    """g with every real pole p moved to p^(1/factor) (time constant times factor), DC gain kept."""
    poles = g.poles()
    if len(poles) == 0 or np.any(np.abs(poles.imag) > 1e-9) or np.any(poles.real <= 0):
        return None
    new_den = np.real(np.poly(poles.real ** (1.0 / factor)))
    scale = g.dc_gain() * new_den.sum() / g.num.sum()
    return TransferFunction(np.asarray(g.num) * scale, new_den, g.delay)


def _unit_foptd(pole: float, delay: int) -> TransferFunction:
    return TransferFunction([1.0 - pole], [1.0, -pole], delay)


def _process_shapes(sig: Signals, i: int) -> list[_Shape]:
    shapes = []
    for j, name in enumerate(sig.inputs):
        g, u = sig.rows[i][j], sig.u[:, j]
        if g is None:
            shapes += [_Shape("missing_coupling", name, "input", _unit_foptd(p, d), None, d, 3, u)
                       for p in COUPLING_POLES for d in COUPLING_DELAYS]
            continue
        shapes.append(_Shape("gain", name, "input", g, g, 1.0, 1, u))
        for f in TIME_CONSTANT_FACTORS:
            s = _first_order_with_time_constant(g, f)
            if s is not None:
                shapes.append(_Shape("time_constant", name, "input", s, g, f, 2, u))
        for dd in range(*DELAY_RANGE):
            if dd != 0 and g.delay + dd >= 0:
                shapes.append(_Shape("delay", name, "input", TransferFunction(g.num, g.den, g.delay + dd),
                                     g, g.delay + dd, 2, u))
    # Output drift competes in the same pool: an additive ramp or step on the output from
    # onset tau on (grid of DRIFT_GRID_S). In closed loop the controller cancels a drift with
    # its inputs, so a drift otherwise poses as a channel change fitted to that compensation.
    n = len(sig.time_s)
    hour = 3600.0 / sig.sample_time_s
    grid = max(int(round(DRIFT_GRID_S / sig.sample_time_s)), 1)
    for tau in range(0, max(n - 2 * grid, 1), grid):
        t = np.maximum(np.arange(n) - tau, 0.0)
        shapes.append(_Shape("output_drift", DRIFT_COLUMN, "drift", TransferFunction(), None, tau, 2, t / hour))
        shapes.append(_Shape("output_drift", DRIFT_COLUMN, "drift", TransferFunction(), None, tau, 2,
                             (t > 0).astype(float)))
    for k, name in enumerate(sig.extras):
        z = sig.z[:, k]
        shapes += [_Shape("unmodeled_input", name, "extra", _unit_foptd(p, d), None, d, 3, z)
                   for p in COUPLING_POLES for d in COUPLING_DELAYS]
    return shapes


# --------------------------------------------------------------------------------------------
# Fitting and scoring


@dataclass
class _Fit:
    shape: _Shape
    onset: int
    statistic: float
    heldout: float
    theta: float
    theta_se: float
    theta_folds: tuple
    score: float
    profile: list = field(default_factory=list)   # (label, statistic) of the same effect/column


def _present_in_both_halves(out: _Output, r: np.ndarray, fit: _Fit, cache: dict) -> bool:
    """A changed channel is a lasting effect: with the fitted theta it must lower the squared
    error in the first and in the second half of the data after its onset. The interleaved
    1 h folds cannot see a fit that only works in part of the record (in closed loop, a drift
    that starts later can pose as a channel change present throughout)."""
    if fit.score <= 0.0:
        return True   # rejected later anyway; no need to compute
    psi, nominal = _whitened(out, fit.shape, cache)
    r_without = r if nominal is None else r + nominal
    weight = cache[("weight", id(fit.shape.drive))]
    drop = weight * (r**2 - (r_without - fit.theta * psi) ** 2)
    mid = (fit.onset + len(r)) // 2
    return drop[fit.onset:mid].sum() > 0.0 and drop[mid:].sum() > 0.0


def _preferred(fits: list[_Fit]) -> _Fit:
    """The best-scoring fit, except that a new time constant or delay whose channel scale theta
    is far from 1 is a change of gain *and* dynamics: when the gain-only fit of the same channel
    already gets half of its held-out gain, the gain change is the main effect and is reported."""
    top = max(fits, key=lambda f: f.score)
    if top.shape.effect in ("time_constant", "delay") and abs(top.theta - 1.0) > max(0.2, 3 * top.theta_se):
        gain = [f for f in fits if f.shape.effect == "gain" and f.shape.column == top.shape.column]
        if gain and gain[0].score > 0 and gain[0].heldout >= 0.5 * top.heldout:
            return gain[0]
    return top


def _whitened(out: _Output, shape: _Shape, cache: dict) -> tuple[np.ndarray, np.ndarray | None]:
    """Whitened responses of the candidate shape and of the nominal channel (cached: they do not
    change between the greedy rounds, only the residual does)."""
    key = id(shape)
    if key not in cache:
        drive = np.nan_to_num(shape.drive)
        psi = out.whiten(out.channel_response(shape.shape, drive))
        nkey = (id(shape.nominal), id(shape.drive))
        if shape.nominal is not None and nkey not in cache:
            cache[nkey] = out.whiten(out.channel_response(shape.nominal, drive))
        cache[key] = (psi, cache[nkey] if shape.nominal is not None else None)
    return cache[key]


def _fit_shape(out: _Output, r: np.ndarray, shape: _Shape, min_onset: int, min_segment: int,
               step: int, cache: dict) -> _Fit:
    """Onset scan of one shape on all data and on each fold (the folds feed the held-out test)."""
    psi, nominal = _whitened(out, shape, cache)
    wkey = ("weight", id(shape.drive))
    if wkey not in cache:
        cache[wkey] = out.weight * np.isfinite(shape.drive)
    weight = cache[wkey]
    r_without = r if nominal is None else r + nominal
    tail = slice(min_onset, None)

    def scan(w):
        f = _core.scan_onset(r[tail], r_without[tail], psi[tail], w[tail], min_segment, step)
        return min_onset + f.onset, f

    onset, full = scan(weight)
    folds = []
    for k in (0, 1):
        on_k, f_k = scan(weight * out.fold[k])
        # held-out drop of the squared error on the other fold, theta and onset from this one
        test = (weight * out.fold[1 - k])[on_k:]
        resid = r_without[on_k:] - f_k.theta * psi[on_k:]
        folds.append((f_k.statistic, float(np.sum(test * (r[on_k:] ** 2 - resid**2))), f_k.theta))
    return _Fit(shape, onset, full.statistic, 0.0, full.theta, full.theta_se, tuple(folds), 0.0)


def _best_per_channel(fits: list[_Fit], logn: float) -> list[_Fit]:
    """Per (effect, column): honest two-fold cross-validation of the whole search. On each fold
    the shape (grid point) and onset with the largest in-fold statistic are picked and scored
    on the other fold; the score is the summed held-out gain minus log(N)/2 per parameter.
    The reported fit is the best shape on all data."""
    groups: dict = {}
    for f in fits:
        groups.setdefault((f.shape.effect, f.shape.column), []).append(f)
    out = []
    for group in groups.values():
        top = max(group, key=lambda f: f.statistic)
        heldout = sum(max(group, key=lambda f: f.theta_folds[k][0]).theta_folds[k][1] for k in (0, 1))
        params = top.shape.params + (1 if top.onset > 0 else 0)
        top.heldout = heldout
        top.score = heldout - 0.5 * params * logn
        top.profile = [(f.shape.label, f.statistic) for f in group]
        out.append(top)
    return out


# --------------------------------------------------------------------------------------------
# Entry point


def diagnose(model, data, train_end_s: float | None = None, min_segment_s: float = 3600.0,
             block_s: float = 3600.0, min_effect: float = 0.01) -> DiagnoseResult:
    """Ranked findings (FORMATS.md ``diagnose --json``) for ``model`` against ``data``.

    ``min_effect``: practical significance; a finding must remove at least this fraction of the
    (whitened) one-step error variance after its onset on held-out data. Closed-loop records are
    long, so statistically significant but practically void mismatches (a model one sample off
    in dead time, a gain 3 % off) would otherwise be reported.

    ``train_end_s``: the data before it are taken to agree with the model (operating point
    from them, no onset inside them except a change present from the start).
    """
    if train_end_s is not None and train_end_s < 0:
        raise ValueError(f"--train-end must be >= 0 seconds, got {train_end_s}")
    time_s = data["time"].to_numpy(dtype=float)
    reference = None if train_end_s is None else time_s < train_end_s
    if reference is not None and reference.sum() < 10:
        raise ValueError(f"--train-end {train_end_s} leaves fewer than 10 rows of training data")
    sig = extract(model, data, reference=reference)
    ts = sig.sample_time_s
    min_segment = max(int(round(min_segment_s / ts)), 4 * AR_ORDER)
    block = max(int(round(block_s / ts)), 10)
    step = max(min_segment // 60, 1)
    first_onset = 0 if train_end_s is None else sig.seconds_to_index(train_end_s)
    n = len(time_s)
    if n < 3 * min_segment:
        raise ValueError(f"data: {n} rows are too few for diagnosis (need at least {3 * min_segment})")
    logn = math.log(n)

    outputs = [_Output(sig, i, min_segment, first_onset, block) for i in range(len(sig.outputs))]
    raw: list[tuple[float, Finding]] = []
    for out in outputs:
        raw += _process_findings(out, sig, first_onset, min_segment, step, logn, min_effect)
    # An actuator nonlinearity also looks like gain/dynamics changes of that input's channels:
    # it replaces them when it explains more than they do together.
    for nl_score, nl in _nonlinearity_findings(outputs, sig, first_onset, min_segment, step, logn, min_effect):
        driven = nl.outputs_driven
        rivals = [(s, f) for s, f in raw if f.output in driven and (
            (f.input == nl.input and f.effect in ("gain", "time_constant", "delay")) or f.effect == "output_drift")]
        if nl_score > sum(s for s, _ in rivals):
            raw = [(s, f) for s, f in raw if all(f is not r for _, r in rivals)] + [(nl_score, nl)]
    with_process = {f.output for _, f in raw} | {o for _, f in raw for o in getattr(f, "outputs_driven", ())}
    for out in outputs:
        if out.name not in with_process:
            raw += _noise_findings(out, sig, first_onset, logn)
    raw.sort(key=lambda sf: -sf[0])
    findings = []
    for k, (_, f) in enumerate(raw, start=1):
        f.id = f"F{k}"
        findings.append(f)
    return DiagnoseResult(model=str(model.name), train_end_s=train_end_s, findings=findings,
                          time_s=time_s, residuals={o.name: o.e for o in outputs})


def _process_findings(out: _Output, sig: Signals, first_onset, min_segment, step, logn, min_effect):
    shapes = _process_shapes(sig, out.i)
    r = out.r.copy()
    found = []
    taken: set = set()
    cache: dict = {}
    for _ in range(MAX_FINDINGS_PER_OUTPUT):
        fits = [_fit_shape(out, r, s, first_onset, min_segment, step, cache)
                for s in shapes if s.column not in taken]
        fits = _best_per_channel(fits, logn)
        fits = [f for f in fits if _present_in_both_halves(out, r, f, cache)]
        if not fits:
            break
        top = _preferred(fits)
        if top.score <= 0.0 or top.heldout < min_effect * out.weight[top.onset:].sum():
            break
        taken.add(top.shape.column)
        if top.shape.effect == "output_drift":
            finding = _noise_findings(out, sig, first_onset, logn, drift_onset=int(top.shape.label))
            finding = finding[0][1] if finding else None
            if finding is not None:
                finding.score = top.score
        else:
            finding = _process_finding(out, sig, top)
        if finding is None or not finding.error_after < finding.error_before:
            # the whitened-domain gain does not carry over to the model the update would write
            break
        found.append((top.score, finding))
        # The accepted change stays in the residual the next candidates are fitted to.
        psi, nominal = _whitened(out, top.shape, cache)
        r_without = r if nominal is None else r + nominal
        r = np.where(np.arange(len(r)) >= top.onset, r_without - top.theta * psi, r)
    return found


def _confidence(score_plus_penalty: float, params: int) -> float:
    """P(chi-square(params) < statistic), Wilson-Hilferty: how unlikely the held-out gain is
    under 'no effect'. Held-out gains can be negative: confidence 0 then."""
    x = max(score_plus_penalty, 0.0)
    if x == 0.0:
        return 0.0
    c = 2.0 / (9.0 * params)
    z = ((x / params) ** (1.0 / 3.0) - (1.0 - c)) / math.sqrt(c)
    return 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))


def _ci_from_profile(profile, statistic: float) -> list:
    """Grid values whose statistic is within the chi-square(1) 95 % quantile of the best."""
    inside = [label for label, s in profile if s >= statistic - 3.84]
    return [float(min(inside)), float(max(inside))] if inside else [None, None]


def _process_finding(out: _Output, sig: Signals, fit: _Fit):
    s = fit.shape
    onset_s = float(sig.time_s[fit.onset])
    theta, se = fit.theta, fit.theta_se
    ci = [theta - 1.96 * se, theta + 1.96 * se]
    when = f"since t={onset_s / 3600:.1f} h" if fit.onset > 0 else "throughout the record"
    name = f"{out.name} <- {s.column}"
    # The model update uses the fold-0 estimate (fitted on the even blocks); errors on odd ones.
    theta_fit = fit.theta_folds[0][2]
    if s.effect == "gain":
        estimate = {"gain_ratio": theta, "ci95": ci}
        text = f"gain of {name} about {theta:.2f}x the model's {when}"
    elif s.effect == "time_constant":
        t_old = _time_constant_s(s.nominal, sig.sample_time_s)
        estimate = {"time_constant_ratio": s.label, "time_constant_s": t_old * s.label,
                    "gain_ratio": theta, "ci95": _ci_from_profile(fit.profile, fit.statistic)}
        text = (f"time constant of {name} about {s.label:g}x the model's "
                f"({t_old * s.label:.0f} s instead of {t_old:.0f} s) {when}")
    elif s.effect == "delay":
        estimate = {"delay_samples": int(s.label), "delay_s": s.label * sig.sample_time_s,
                    "model_delay_samples": s.nominal.delay, "gain_ratio": theta,
                    "ci95": _ci_from_profile(fit.profile, fit.statistic)}
        text = (f"dead time of {name} about {s.label * sig.sample_time_s:.0f} s instead of "
                f"{s.nominal.delay * sig.sample_time_s:.0f} s {when}")
    else:
        pole = 1.0 - float(s.shape.num[0])
        estimate = {"gain": theta, "ci95": ci, "delay_samples": int(s.label),
                    "time_constant_s": (-sig.sample_time_s / math.log(pole)) if pole > 0 else 0.0}
        what = "input" if s.kind == "input" else "data column"
        text = (f"{out.name} responds to {what} {s.column} (gain about {theta:.3g}, "
                f"delay {int(s.label)} samples) but the model has no such channel, {when}")
    new_channel = TransferFunction(np.asarray(s.shape.num) * theta_fit, s.shape.den, s.shape.delay)
    change = ModelChange(output=out.name, input=s.column, channel=new_channel,
                         new_input=s.kind == "extra")
    before, after = _held_out_errors(out, sig, fit.onset, change)
    params = s.params + (1 if fit.onset > 0 else 0)
    f = Finding(id="", effect=s.effect, output=out.name, input=s.column, onset_s=onset_s,
                confidence=_confidence(fit.heldout, params), estimate=estimate,
                error_before=before, error_after=after, explanation=text, score=fit.score,
                change=change)
    return f


def _time_constant_s(g: TransferFunction, ts: float) -> float:
    p = float(np.max(np.abs(g.poles()))) if len(g.poles()) else 0.0
    return -ts / math.log(p) if 0.0 < p < 1.0 else 0.0


def _held_out_errors(out: _Output, sig: Signals, onset: int, change: ModelChange):
    """RMS one-step error on the odd blocks after onset: nominal model vs changed model."""
    test = out.fold[1].astype(bool) & (np.arange(len(out.e)) >= onset) & np.isfinite(out.e)
    after_e = one_step_errors(sig, out.i, [change])
    test &= np.isfinite(after_e)
    if not test.any():
        return float("nan"), float("nan")
    return float(np.sqrt(np.mean(out.e[test] ** 2))), float(np.sqrt(np.mean(after_e[test] ** 2)))


def one_step_errors(sig: Signals, i: int, changes: list[ModelChange]) -> np.ndarray:
    """One-step prediction errors of output i with the model after ``changes``."""
    name = sig.outputs[i]
    row = list(sig.rows[i])
    noise = sig.noise[i]
    u = sig.u
    extra_cols = []
    for c in changes:
        if c.output != name:
            continue
        if c.noise is not None:
            noise = c.noise
        if c.channel is not None:
            if c.new_input:
                extra_cols.append((c.channel, sig.z[:, sig.extras.index(c.input)]))
            else:
                row[sig.inputs.index(c.input)] = c.channel
    v = per_segment(sig, lambda yy, uu: _core.output_error(row, yy, uu), sig.y[:, i], u)
    for g, z in extra_cols:
        v = v - per_segment(sig, g.filter, np.nan_to_num(z))
        v[~np.isfinite(z)] = np.nan
    return per_segment(sig, lambda vv: noise.inverse().filter(np.nan_to_num(vv)), v) * np.where(np.isfinite(v), 1.0, np.nan)


# --------------------------------------------------------------------------------------------
# Actuator nonlinearity


def _nonlinearity_findings(outputs, sig, first_onset, min_segment, step, logn, min_effect):
    """Backlash or stick-slip on an input: every channel from it sees f(u) instead of u."""
    found = []
    for j, name in enumerate(sig.inputs):
        u = np.nan_to_num(sig.u[:, j])
        moves = np.abs(np.diff(u))
        scale = float(np.median(moves[moves > 0])) if np.any(moves > 0) else 0.0
        if scale == 0.0:
            continue
        best = None
        for kind, width_factor in [(k, w) for k in ACTUATOR_KINDS for w in BACKLASH_WIDTHS]:
            width = width_factor * scale
            moved = getattr(_core, kind)(u, width)
            ub = moved - np.mean(moved)
            heldout, per_out = 0.0, []
            for out in outputs:
                g = out.row[j]
                if g is None:
                    continue
                shape = _Shape("input_nonlinearity", name, "input", g, g, width, 1, ub)
                # The plant sees f(u) = u + (f(u) - u): the candidate adds G (f(u) - u) to the
                # nominal G u with no free scale (the channel itself is unchanged). A free scale
                # would let a very wide backlash (f(u) nearly constant, f(u) - u ~ -u) pose as a
                # plain gain change.
                psi = out.whiten(out.channel_response(g, ub - u))
                drop = out.weight * (out.r**2 - (out.r - psi) ** 2)

                def best_onset(w):
                    suffix = np.cumsum((drop * w)[::-1])[::-1]
                    ks = np.r_[first_onset, np.arange(first_onset + min_segment, len(u) - min_segment + 1, step)]
                    k = int(ks[np.argmax(suffix[ks])])
                    return k, float(suffix[k])

                onset, stat = best_onset(np.ones(len(u)))
                h = 0.0
                for k in (0, 1):
                    on_k, _ = best_onset(out.fold[k])
                    h += float(np.sum((drop * out.fold[1 - k])[on_k:]))
                heldout += h
                per_out.append((out, shape, onset, 1.0, 1.0, h))
            if not per_out:
                continue
            params = 2 + 1   # kind and width, onset
            score = heldout - 0.5 * params * logn
            if best is None or score > best[0]:
                best = (score, heldout, width, per_out, params, kind)
        if best is None or best[0] <= 0.0:
            continue
        score, heldout, width, per_out, params, kind = best
        n_after = sum(o.weight[on:].sum() for o, _, on, _, _, _ in per_out)
        if heldout < min_effect * n_after:
            continue
        out0, _, onset, theta, _, _ = max(per_out, key=lambda p: p[5])
        onset_s = float(sig.time_s[onset])
        # The fixed model format has no actuator block: update applies the describing-function
        # gain, the linear channel scale theta that best matches the backlash response.
        changes = [ModelChange(output=o.name, input=name,
                               channel=TransferFunction(np.asarray(sh.nominal.num) * _describing_gain(u, sh.drive, th_fit),
                                                        sh.nominal.den, sh.nominal.delay))
                   for o, sh, _, _, th_fit, _ in per_out]
        before, after = _held_out_errors(out0, sig, onset, changes[[o for o, *_ in per_out].index(out0)])
        if not after < before:
            continue
        theta = _describing_gain(u, per_out[0][1].drive, theta)
        f = Finding(id="", effect="input_nonlinearity", output=out0.name, input=name, onset_s=onset_s,
                    confidence=_confidence(heldout, params),
                    estimate={"kind": kind, "width": width, "ci95": [width / 2, width * 2],
                              "equivalent_gain_ratio": theta},
                    error_before=before, error_after=after,
                    explanation=(f"actuator {name} behaves like a {kind.replace('_', '-')} of about "
                                 f"{width:.3g} units (small moves do not reach the process)"
                                 + (f" since t={onset_s / 3600:.1f} h" if onset > 0 else "")),
                    score=score, change=changes[0])
        f.extra_changes = [c for c in changes if c.output != out0.name]
        f.change = next(c for c in changes if c.output == out0.name)
        f.outputs_driven = tuple(o.name for o, *_ in per_out)
        found.append((score, f))
    return found


def _describing_gain(u: np.ndarray, moved: np.ndarray, theta: float) -> float:
    """Least-squares scale k with k u ~ u + theta (f(u) - u): the linear channel gain ratio
    that best reproduces the nonlinear actuator (what the fixed model format can hold)."""
    x = u - u.mean()
    target = x + theta * ((moved - moved.mean()) - x)
    return float(x @ target / (x @ x)) if x @ x > 0 else 1.0


# --------------------------------------------------------------------------------------------
# Disturbance-side findings


def _noise_findings(out: _Output, sig: Signals, first_onset: int, logn: float, drift_onset=None):
    """noise_change / output_drift on an output whose process model passed; with drift_onset
    (a drift won in the process pool) only the drift noise model from that onset."""
    e = out.e
    ok = np.isfinite(e) & (out.weight > 0)
    ramp_onset, ramp_stat = (drift_onset, 0.0) if drift_onset is not None else _drift_onset(out, first_onset)
    if drift_onset is not None:
        onset = drift_onset
    elif out.split_significant:
        onset = out.split_onset
    elif ramp_stat > 3 * logn:
        onset = ramp_onset
    else:
        onset = first_onset
    after = ok & (np.arange(len(e)) >= onset)
    fold = [out.fold[0].astype(bool) & after, out.fold[1].astype(bool) & after]
    e0 = np.nan_to_num(e)
    n_after = int(after.sum())
    if n_after < 4 * AR_ORDER:
        return []

    def heldout_gain(make_filter):
        """sum over both folds of n_test log(var nominal / var filtered), filter fitted on the other fold."""
        gain = 0.0
        for k in (0, 1):
            filt = make_filter(fold[k])
            w = filt.filter(e0)
            test = fold[1 - k]
            gain += test.sum() * math.log(np.mean(e0[test] ** 2) / np.mean(w[test] ** 2))
        return gain

    def ar_on(mask):
        return TransferFunction(_masked_ar(e0, mask), [1.0], 0)

    candidates = []
    noise_gain = heldout_gain(ar_on)
    level = 0.0
    if out.split_significant and out.split.variance_before > 0:
        # Innovation level: likelihood ratio of separate variances (AR colour already fitted).
        ratio = out.split.variance_after / out.split.variance_before
        nb, na = onset - first_onset, n_after
        pooled = (nb * out.split.variance_before + na * out.split.variance_after) / (nb + na)
        level = (nb + na) * math.log(pooled) - nb * math.log(out.split.variance_before) - na * math.log(
            out.split.variance_after)
    else:
        ratio = 1.0
    onset_params = 1 if onset > first_onset else 0
    noise_score = max(noise_gain - (AR_ORDER + onset_params) * logn, level - (1 + onset_params) * logn)
    candidates.append(("noise_change", noise_score, noise_gain, level))

    # A slow drift on top of the modelled disturbance: v = H e + d with d a slowly wandering
    # level has the innovations form H (1 - c q^-1) / (1 - rho q^-1), rho close to 1 (the
    # drift) and c < rho (how fast the level wanders); rho < 1 keeps H stable as FORMATS asks.
    drift_best = None
    for rho in DRIFT_POLES:
        for c in DRIFT_ZEROS:
            g = heldout_gain(lambda mask, rho=rho, c=c: TransferFunction([1.0, -rho], [1.0, -c], 0))
            if drift_best is None or g > drift_best[2]:
                drift_best = (rho, c, g)
    drift_score = drift_best[2] - (2 + onset_params) * logn
    candidates.append(("output_drift", drift_score, drift_best[2], 0.0))
    if drift_onset is not None:
        candidates = [c for c in candidates if c[0] == "output_drift"]
    effect, score, gain, level = max(candidates, key=lambda c: c[1])
    if score <= 0.0 and drift_onset is None:
        return []
    onset_s = float(sig.time_s[onset])
    when = f"since t={onset_s / 3600:.1f} h" if onset > first_onset else "throughout the record"
    if effect == "noise_change":
        poly = _stable(_masked_ar(e0, after))
        noise = TransferFunction(out.noise.num, np.convolve(out.noise.den, poly), 0)
        se = math.sqrt(2.0 / max(n_after, 1) + 2.0 / max(onset - first_onset, 1))
        estimate = {"variance_ratio": ratio, "ci95": [ratio * math.exp(-1.96 * se), ratio * math.exp(1.96 * se)],
                    "noise_den": list(map(float, noise.den))}
        text = (f"the disturbance on {out.name} changed {when} (innovation variance x{ratio:.2f}, "
                f"new colour); the process model still fits")
        params = AR_ORDER + onset_params
        conf_stat = max(gain, level)
    else:
        rho, c = drift_best[0], drift_best[1]
        noise = TransferFunction(np.convolve(out.noise.num, [1.0, -c]), np.convolve(out.noise.den, [1.0, -rho]), 0)
        estimate = {"drift_pole": rho, "ci95": [min(DRIFT_POLES), max(DRIFT_POLES)], "drift_zero": c,
                    "drift_time_constant_s": -sig.sample_time_s / math.log(rho)}
        text = f"slow drift on {out.name} {when}; the process model still fits"
        params = 2 + onset_params
        conf_stat = gain
    change = ModelChange(output=out.name, noise=_refit_noise(out, effect, fold[0], e0, noise))
    before, after_err = _held_out_errors(out, sig, onset, change)
    # A pure level change is a real disturbance change the model file cannot hold (H is monic,
    # the innovation variance is not in FORMATS.md), so it need not lower the error.
    level_driven = effect == "noise_change" and level - (1 + onset_params) * logn >= noise_gain - (
        AR_ORDER + onset_params) * logn
    if not after_err < before and not level_driven:
        return []
    return [(score, Finding(id="", effect=effect, output=out.name, input=None, onset_s=onset_s,
                            confidence=_confidence(conf_stat, params), estimate=estimate,
                            error_before=before, error_after=after_err, explanation=text,
                            score=score, change=change))]


def _drift_onset(out: _Output, first_onset: int, grid: int = 120):
    """Onset of an additive step + ramp on the output (see ``_trend_fit``), with the drop of
    the residual sum of squares in units of the early error variance."""
    k, drop, _ = _trend_fit(np.nan_to_num(out.e), out.weight > 0, out.noise.inverse(), first_onset, grid)
    return k, drop / out.sigma[0] ** 2


def _trend_fit(e: np.ndarray, ok: np.ndarray, hinv: TransferFunction, first_onset: int, grid: int):
    """Least squares of the one-step error e on H^-1 [1, step(t - k), ramp(t - k)] for onsets
    k on a grid (the AR correction is left out: it would whiten a drift away). Returns the best
    k, the drop of the residual sum of squares and the fitted step + ramp part."""
    n = len(e)
    t = np.arange(n, dtype=float)
    step0, ramp0 = hinv.filter(np.ones(n)), hinv.filter(t / n)
    base = np.ones(n)
    rss0 = np.sum((e[ok] - e[ok].mean()) ** 2)
    best = (first_onset, 0.0, np.zeros(n))
    for k in range(max(first_onset, 2 * SETTLE), n - 2 * grid, grid):
        x = np.column_stack([base, np.r_[np.zeros(k), step0[: n - k]], np.r_[np.zeros(k), ramp0[: n - k]]])
        coef = np.linalg.solve(x[ok].T @ x[ok] + 1e-12 * np.eye(3), x[ok].T @ e[ok])
        drop = rss0 - np.sum((e[ok] - x[ok] @ coef) ** 2)
        if drop > best[1]:
            best = (k, float(drop), x[:, 1:] @ coef[1:])
    return best


def _refit_noise(out, effect, fit_mask, e0, full_noise):
    """The noise model update writes: refitted on the fit blocks only (errors on the others)."""
    if effect == "output_drift":
        return full_noise
    poly = _stable(_masked_ar(e0, fit_mask))
    return TransferFunction(out.noise.num, np.convolve(out.noise.den, poly), 0)


def _masked_ar(e: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Least-squares AR(AR_ORDER) on the rows in mask (lags may reach outside it)."""
    rows = np.flatnonzero(mask)
    rows = rows[rows >= AR_ORDER]
    lagged = e[rows[:, None] - np.arange(1, AR_ORDER + 1)]
    a = np.linalg.solve(lagged.T @ lagged, lagged.T @ e[rows])
    return np.r_[1.0, -a]


def _stable(poly: np.ndarray) -> np.ndarray:
    """Reflect roots outside the unit circle inside (same spectrum shape): H/A must be stable."""
    roots = np.roots(poly)
    if np.all(np.abs(roots) < 1.0):
        return poly
    mag = np.abs(roots)
    roots = np.where(mag >= 1.0, np.minimum(1.0 / np.maximum(mag, 1e-12), 0.999) * roots / np.maximum(mag, 1e-12), roots)
    return np.real(np.poly(roots))


def _rounded(v):
    if isinstance(v, float):
        return round(v, 6) if math.isfinite(v) else None
    if isinstance(v, list):
        return [_rounded(x) for x in v]
    return v
