"""A model file from routine closed-loop data (``mpmpp identify``).

Per output, y = sum_j G_j u_j + H e is fitted by the ARX-OE of ``mpmpp.identify`` (paper
Section 3): the ARX step's A(q) whitens the disturbance, so the OE fit on A-filtered data is the
prediction-error fit with H = 1/A, which stays consistent under feedback (the direct method).
A self-regulating output's disturbance may also carry a moving-average root,
H = (1 - c q^-1) / A (``MA_ROOTS``, ``_moving_average_root``): the same fit on the data through
1 / (1 - c q^-1). A sinusoidal disturbance from outside the loop may be set apart
(``_external_oscillation``): the same search on y and u with their component at the output's
periodogram peak projected out.

Model classes, per output (``PROCESS_CLASSES``; every channel of an output in the same class):
first order plus dead time, G = q^-d (b0 + b1 q^-1) / (1 - a q^-1), the zero-order-hold
discretisation of K e^(-theta s) / (tau s + 1) (b1 carries a dead time that is not a whole number
of samples, as in docs/formats.md's FOPTD form); and integrating, a level that integrates its
inflows, K e^(-theta s) / s or K e^(-theta s) / (s (tau s + 1)), K the rate gain. An integrating
output is fitted in the differenced domain, (1 - q^-1) y = G' u + e / A(q), where G' is a FIR
(pure integrator) or first-order (with lag) channel; its model file channel is
G = G' / (1 - q^-1), a pole at 1, which the discrete form holds as it is. The one-step
prediction error of y is A (1 - q^-1) (y - G u) = A ((1 - q^-1) y - G' u), the same quantity the
first-order class minimises, so the classes compete by the same BIC on the same rows. When the
disturbance is at the output (transmitter noise) rather than an inflow, H = 1 / A and the level
is fitted against the integrated input, y = G' (u / (1 - q^-1)) + e / A.

Search, per output: the delay d of every channel, its numerator length (1 or 2) and the ARX
(noise) order na. Lag 0 is never searched when the data show feedback: a PI loop's OP reacts to
PV within the sample, and a channel at lag 0 would fit that controller path (the inverse
controller, with the sign of the gain flipped) instead of the process.

Selection: BIC on the one-step prediction errors A (y - G u) over one common sample range. BIC
rather than a held-out fit because a historian export is short (a 2 h export at 10 s is 751
rows) and halving it for validation doubles the spread of every estimate, and because the
candidates are nested low orders, where BIC is consistent. A channel counts K, theta and tau
whatever its numerator length (the dead time is continuous), and first order stays the class
unless an integrating one wins clearly (``_choose_class``).

Uncertainty: K and tau by the delta method on the joint covariance of G's and H's parameters
(under feedback they are correlated: the OE covariance, H held fixed, understates the spread of
G); the dead time from the profile
of the criterion over the searched dead times (likelihood-ratio 95 % interval), since the
delta method cannot see a discrete search.

Verdicts: an input that does not move, or an output none of whose channels has an effect, is "not
identified" (``NotIdentified``). A channel has one when its gain is distinguishable from zero at
the level corrected for the dead times searched (Bonferroni), or when its numerator is (the Wald
test of b = 0 at that level: G = 0 exactly when b = 0) and its gain is at 95 %; the class choice
uses the first, firm reading only. A SISO loop whose gain has the sign opposite to the
controller's action (the feedback path fitted as the process) needs |K| / sd(K) >= SIGN_FLIP_Z,
else it is not identified either, and such a class cannot replace another in the class choice.
"""
from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from dataclasses import asdict, dataclass, field, fields
from statistics import NormalDist

import numpy as np

from . import _core
from .io import json_safe
from .foptd import integrating_reading
from .identify import arx_oe, oe
from .periodic_disturbance import dominant_frequency, without_sinusoid
from .record_length import MIN_ROWS, require_rows
from .held_values import frozen, require_computable
from .signals import bridge_lost_outputs, complete_runs, missing_counts
from .stretches import Stretches
from .timeaxis import sample_grid, seconds_of

NA_ORDERS = (1, 2, 3, 5, 8)      # ARX / noise orders searched
# Moving-average roots c of the disturbance model H = (1 - c q^-1) / A(q), chosen by BIC with
# the rest. A wandering disturbance (nearly integrated, IMA(1,1)-like, as most plants' are) needs
# a root near 1 that no AR of the searched orders holds, and the disturbance the AR leaves
# coloured then biases G in closed loop (the direct method): on the tuning family
# pi_siso_wander, seeds 0-19, the time constant's 95 % interval held the truth in 5 of 20
# records with AR noise models (docs/identify.md "A wandering disturbance").
MA_ROOTS = (0.0, 0.5, 0.7, 0.8, 0.9)
NUMERATOR_LENGTHS = (1, 2)       # 2: dead time between samples
Z95 = 1.959963984540054
CHI2_1_95 = 3.841458820694124    # 95 % quantile of chi-square(1): profile-likelihood interval
# BIC difference (2 log Bayes factor) an integrating class needs over an identified first-order
# fit: "strong" evidence on Kass & Raftery's scale (JASA 1995)
CLASS_MARGIN = 6.0
# A sinusoidal disturbance set apart (_external_oscillation) costs its amplitude, phase and
# frequency, and must then win by "very strong" evidence (Kass & Raftery), the frequency being the
# best of a search. Chosen a priori; on the stiction study's tuning loops (flow, level, level with
# a load, temperature; seeds 7001-7004, 112 records) the loops with an external sinusoid won by
# 15-68 and the others by at most 6.9 (a sticking level valve), 2.1 and 1.1.
OSCILLATION_PARAMS = 3
OSCILLATION_MARGIN = 10.0
# BIC difference the disturbance at the output needs over an inflow disturbance for an integrating
# output: "very strong" on the same scale (on routine tank records the two forms are confused
# within 8)
OUTPUT_NOISE_MARGIN = 10.0
SIGN_FLIP_Z = 5.0                # "overwhelming evidence" for a gain against the controller's action
DEFAULT_MAX_DEAD_TIME_S = 600.0
# Candidates whose search criterion is this far above the best (n log(V / V_best)) are not
# refined: refinement lowers V, but not by that much; 5 times the 95 % profile threshold.
PRUNE = 5 * 3.841458820694124


@dataclass(frozen=True)
class ProcessClass:
    """A channel's model class: whether the output integrates it, the denominator order nf of
    the part that is fitted (of G, or of G' = (1 - q^-1) G for an integrating output), and the
    parameters per channel BIC counts. A class is counted as the self-regulating family it is the
    boundary of: K e^(-theta s) / s is K tau e^(-theta s) / (tau s + 1) as tau -> infinity, so
    it has first order plus dead time's three (the limit is not a simpler model: on routine
    closed-loop data a flow loop's one-step errors fit both equally, and two parameters made the
    integrator win there); with a lag it is the limit of two lags, four.

    An integrating output's disturbance either integrates too (an unmeasured inflow: H = 1 /
    (A (1 - q^-1)), fitted on the differenced output) or does not (transmitter noise, waves on the
    surface: H = 1 / A, fitted on the output with the input integrated, y = G' (u / (1 - q^-1)));
    ``noise_integrates`` says which."""
    name: str
    integrating: bool
    nf: int
    parameters: int
    noise_integrates: bool = True


SELF_REGULATING = ProcessClass("first order plus dead time", False, 1, 3)
INTEGRATING = ProcessClass("integrating plus dead time", True, 0, 3)
INTEGRATING_LAG = ProcessClass("integrating with first-order lag plus dead time", True, 1, 4)
INTEGRATING_OUTPUT_NOISE = ProcessClass("integrating plus dead time, disturbance at the output", True, 0, 3,
                                        noise_integrates=False)
PROCESS_CLASSES = (SELF_REGULATING, INTEGRATING, INTEGRATING_LAG, INTEGRATING_OUTPUT_NOISE)
CLASSES_BY_NAME = {"auto": PROCESS_CLASSES, "self-regulating": (SELF_REGULATING,),
                   "integrating": (INTEGRATING, INTEGRATING_LAG, INTEGRATING_OUTPUT_NOISE)}


class NotIdentified(ValueError):
    """The data do not identify the loop (the message says why)."""


@dataclass
class ChannelSummary:
    output: str
    input: str
    gain: float
    gain_sd: float
    time_constant_s: float
    time_constant_sd: float
    dead_time_s: float
    dead_time_ci95: tuple[float, float]
    delay_samples: int
    numerator_length: int
    significant: bool                   # |gain| / gain_sd >= significance_z(dead times searched)
    integrating: bool = False           # gain is then the rate gain (output units per s per input unit)
    effect: bool = False                # the numerator is not 0 at the search-corrected level (``_has_effect``)
    unexcited: bool = False             # the input is the output's controller law and nothing else moves it

    @property
    def kept(self) -> bool:
        """In the model: a gain firm at the search-corrected level, or an effect (``_has_effect``)
        whose gain is distinguishable from 0 at 95 %."""
        return bool(self.significant or (self.effect and abs(self.gain) >= Z95 * self.gain_sd))

    @property
    def uncertain(self) -> bool:
        """Usable but loosely determined: sd(K) above 25 % of |K|, sd(tau) above 50 % of tau, or
        an input that only the controller moved (``unexcited``: then sd(K) is no guide)."""
        return bool(self.gain_sd > 0.25 * abs(self.gain) or self.unexcited
                    or (self.time_constant_s > 0 and not self.time_constant_sd <= 0.5 * self.time_constant_s))

    @property
    def dead_time_sd(self) -> float:
        """The profile interval's half width / 1.96 (its normal-equivalent spread)."""
        return (self.dead_time_ci95[1] - self.dead_time_ci95[0]) / (2 * Z95)

    def describe(self) -> str:
        if self.integrating:
            dynamics = (f"integrating, rate gain {self.gain:.4g} +- {self.gain_sd:.2g} per s, "
                        + (f"lag {self.time_constant_s:.4g} +- {self.time_constant_sd:.2g} s, "
                           if self.time_constant_s > 0 else ""))
        else:
            dynamics = (f"gain {self.gain:.4g} +- {self.gain_sd:.2g}, "
                        f"time constant {self.time_constant_s:.4g} +- {self.time_constant_sd:.2g} s, ")
        return (f"{self.output} <- {self.input}: {dynamics}"
                f"dead time {self.dead_time_s:.4g} s (95 % {self.dead_time_ci95[0]:.4g}-"
                f"{self.dead_time_ci95[1]:.4g} s)"
                + ("" if self.kept else ", NOT significant: left out")
                + (", UNCERTAIN: excite the loop (e.g. setpoint steps) for a firmer model"
                   if self.kept and self.uncertain else "")
                + (f" ({self.input} follows the controller exactly and nothing else moves it: such a "
                   "record does not determine the process, and the gain may be far off)"
                   if self.kept and self.unexcited else ""))


@dataclass
class OutputFit:
    output: str
    noise_order: int                    # na of H = 1/A(q)
    bic: float
    fit_one_step: float                 # fit % of the one-step prediction
    fit_simulation: float               # fit % of the simulation G u (what `compare` calls simulation)
    candidates: int                     # models compared by BIC
    feedback: str                       # controller action seen in the data (SISO): direct, reverse, none
    process_class: str = SELF_REGULATING.name  # the ProcessClass BIC chose
    noise_root: float = 0.0             # c of H = (1 - c q^-1) / A(q) (MA_ROOTS); 0: H = 1/A(q)
    # a sinusoidal disturbance at the output set apart from the fit (``_external_oscillation``):
    # its period and amplitude (output units); None when there is none
    oscillation_period_s: float | None = None
    oscillation_amplitude: float | None = None
    # an integrating class chosen although first order plus dead time fits better by CLASS_MARGIN
    # or more (``_settling_alternative``): what first order reads; None otherwise
    class_open: str | None = None


@dataclass
class IdentificationResult:
    model: object = field(repr=False)   # mpmpp Model
    sample_time_s: float
    rows_used: int
    skipped_rows: int
    channels: list[ChannelSummary]
    outputs: list[OutputFit]
    selection: str = "BIC on one-step prediction errors over a common sample range"
    interpolated_samples: int = 0       # lost output samples interpolated (signals.bridge_lost_outputs)

    def to_dict(self) -> dict:
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "model"}
        d["channels"] = [{**asdict(c), "dead_time_ci95": list(c.dead_time_ci95), "dead_time_sd": c.dead_time_sd,
                          "uncertain": c.uncertain, "kept": c.kept} for c in self.channels]
        d["outputs"] = [asdict(o) for o in self.outputs]
        return json_safe(d)

    def summary(self) -> str:
        lines = [f"identify: {self.rows_used} rows at {self.sample_time_s:g} s"
                 + (f" ({self.skipped_rows} rows skipped: missing values, time gaps or stretches between them "
                    f"too short to fit)" if self.skipped_rows else "")
                 + (f" ({self.interpolated_samples} lost output sample(s) interpolated)"
                    if self.interpolated_samples else "")
                 + f"; orders and dead times by {self.selection}"]
        for o in self.outputs:
            lines.append(f"  {o.output} ({o.process_class}): fit 1-step {o.fit_one_step:.1f} %,"
                         f" simulation {o.fit_simulation:.1f} %;"
                         f" noise model AR({o.noise_order})"
                         + (f" with a moving-average root {o.noise_root:g} (a wandering disturbance)"
                            if o.noise_root else "")
                         + (f"; an oscillation from outside the loop set apart (period {o.oscillation_period_s:.4g} s, "
                            f"amplitude {o.oscillation_amplitude:.3g}; not in the model)"
                            if o.oscillation_period_s is not None else "")
                         + f"; {o.candidates} candidates"
                         + (f"; controller action {o.feedback}" if o.feedback != "none" else ""))
            if o.class_open:
                lines.append(f"    the class is open: {o.class_open}")
            for c in self.channels:
                if c.output == o.output:
                    lines.append(f"    {c.describe()}")
        return "\n".join(lines)

    def save(self, path, overwrite: bool = False) -> None:
        """Write the model file (atomically; an existing file only with ``overwrite``)."""
        if os.path.exists(path) and not overwrite:
            raise ValueError(f"{os.fspath(path)}: exists (pass --force / overwrite=True to replace it)")
        _core.save_model(self.model, os.fspath(path))


def model_from_data(data, inputs, outputs, *, setpoints=None, name: str | None = None,
                    max_dead_time_s: float | None = None, min_delay: int = 1,
                    na_orders=NA_ORDERS, numerator_lengths=NUMERATOR_LENGTHS,
                    classes=PROCESS_CLASSES, workers: int | None = None) -> IdentificationResult:
    """Identify a model of ``outputs`` from ``inputs`` (column names) in ``data`` (a DataFrame
    with a ``time`` column in seconds, or a data file path). The sample time comes from the time
    column. ``setpoints``: one setpoint column per output (default ``<output>_sp`` where
    present), used only to read the controller's action. ``max_dead_time_s``: longest dead
    time searched (default DEFAULT_MAX_DEAD_TIME_S, at most a tenth of the record).
    ``min_delay`` 0 is refused when the data show feedback from the output to any input.
    ``classes``: the ProcessClass candidates per output (BIC picks one). ``workers``: threads
    for the search (default: one per core, up to one per noise order; the result is the same).
    Raises ``NotIdentified`` when the data do not identify the loop, ``ValueError`` on bad
    input. A data file is put on its own sample grid with the historian repairs
    (``io.load_loop_data``; its splits are kept apart)."""
    from .io import load_loop_data

    inputs, outputs, setpoints = loop_columns(inputs, outputs, setpoints)
    if not hasattr(data, "columns"):
        data = load_loop_data(data, inputs + outputs + (setpoints or []))
    classes = tuple(classes)
    if not classes or not all(isinstance(c, ProcessClass) for c in classes):
        raise ValueError(f"classes: give one or more ProcessClass (e.g. PROCESS_CLASSES), got {classes!r}")
    if setpoints is None:
        setpoints = [f"{o}_sp" if f"{o}_sp" in data.columns else None for o in outputs]
    for col in ["time", *inputs, *outputs, *[c for c in setpoints if c]]:
        if col not in data.columns:
            raise ValueError(f"data: no column {col!r} (columns: {', '.join(map(str, data.columns))})")
    raw = data[inputs + outputs].to_numpy(dtype=float, copy=True)
    time_s = seconds_of(data)
    require_computable(inputs + outputs, raw, time_s)
    ts, gaps = sample_grid(time_s, data.attrs.get("segment_starts", ()))
    require_rows(len(raw), ts)
    # A few lost output samples are interpolated rather than cutting the record into stretches,
    # each fitted from rest (signals.bridge_lost_outputs). They stay in the criterion (the C++
    # estimators take no row mask): on 2 h PI test loops with 4-7 lost PV samples K and tau
    # moved 0-0.6 % (median) from the complete record's estimates, against 3-50 % cut; on the
    # held-out loops of studies/standing_errors.py 0-1.7 % against 1-100 %.
    raw[:, len(inputs):], bridged = bridge_lost_outputs(raw[:, len(inputs):], raw[:, :len(inputs)], gaps)
    runs = complete_runs(np.all(np.isfinite(raw), axis=1), gaps)
    if max_dead_time_s is None:
        max_dead_time_s = DEFAULT_MAX_DEAD_TIME_S
    if not max_dead_time_s >= 0:
        raise ValueError(f"max_dead_time_s must be >= 0, got {max_dead_time_s}")
    max_delay = int(min(np.floor(max_dead_time_s / ts) + 1, sum(b - a for a, b in runs) // 10))
    # Every complete stretch at least twice the criterion's start-up (t0 below) is fitted, each
    # from rest (``Stretches``): at least half its rows enter the criterion, and the unknown
    # state at its start (the filters start at rest) weighs on no more rows than it adds.
    shortest = 2 * (max_delay + max(na_orders))
    runs = [(a, b) for a, b in runs if b - a >= shortest]
    n = sum(b - a for a, b in runs)
    if n < MIN_ROWS:
        # a long record (require_rows passed) with scattered missing values is not "too short"
        raise ValueError(f"data: the stretches of at least {shortest} rows without missing values or time gaps "
                         f"hold {n} of {len(raw)} rows, need {MIN_ROWS} ({missing_counts(inputs + outputs, raw)})")
    rows = np.concatenate([np.arange(a, b) for a, b in runs])
    st = Stretches([b - a for a, b in runs])
    raw = raw[rows]
    dev = raw - raw.mean(axis=0)
    U, Y = dev[:, :len(inputs)], dev[:, len(inputs):]
    for j, col in enumerate(inputs):
        if not np.std(U[:, j]) > 1e-9 * max(1.0, float(np.abs(raw[:, j]).max())):
            raise NotIdentified(f"not identified: input {col!r} does not move (no excitation)")
    for i, col in enumerate(outputs):
        if frozen(Y[:, i]):
            raise NotIdentified(f"not identified: output {col!r} does not move (one value throughout: a frozen tag "
                                "or a stuck transmitter)")
    sp = {o: data[c].to_numpy(dtype=float)[rows] if c else None for o, c in zip(outputs, setpoints)}
    process, noise, summaries, fits = {}, {}, [], []
    workers = min(os.cpu_count() or 1, len(na_orders)) if workers is None else int(workers)
    with ThreadPoolExecutor(workers) if workers > 1 else nullcontext() as pool:
        for i, out in enumerate(outputs):
            actions = [_controller_action(U[:, j], raw[:, len(inputs) + i], sp[out], st.starts)
                       for j in range(len(inputs))]
            # the sign guard needs the loop's pairing, known only for a single input
            action = actions[0] if len(inputs) == 1 else 0
            if min_delay < 1 and any(actions):
                raise ValueError(f"lag 0 cannot be searched for {out!r}: the data show feedback "
                                 "(the controller reacts to the output within the sample)")
            z = significance_z(max_delay - max(min_delay, 0) + 1)
            search = _OutputSearch(out, inputs, ts, z, max(min_delay, 0), max_delay, tuple(na_orders),
                                   tuple(numerator_lengths), pool, st)
            chosen = _output_fit(Y[:, i], U, classes, action, search, n * ts)
            if chosen is None:
                raise NotIdentified("not identified: no candidate model could be fitted (data not informative)")
            oscillation = _external_oscillation(Y[:, i], U, rows, chosen, classes, action, search, n * ts)
            if oscillation is not None:
                chosen = oscillation.choice
            fitted, cls, root, count = chosen.fitted, chosen.fit.cls, chosen.root, chosen.count
            best, chans = chosen.fit.best, chosen.fit.channels
            for j, c in enumerate(chans):
                c.unexcited = all(_controller_law_exact(U[a:b, j], raw[a:b, len(inputs) + i],
                                                        None if sp[out] is None else sp[out][a:b])
                                  for a, b in st.spans())
            try:
                _check_verdict(out, chans, action)
            except NotIdentified as refusal:
                raise NotIdentified(str(refusal) + _integrating_alternative(fitted, cls)
                                    + (f"; {oscillation.describe(ts)} first, and what is left does not identify "
                                       "the loop" if oscillation else "")) from None
            tf, a = _output_domain(best, cls)
            process[out] = {c.input: tf[j] for j, c in enumerate(chans) if c.kept}
            na = len(best.a)
            if oscillation is not None:
                na, a = _disturbance_with_oscillation(process[out], cls, root, Y[:, i], U, search)
            noise[out] = _core.TransferFunction(np.array([1.0, -root]) if root else np.ones(1), _stable_monic(a), 0)
            summaries += chans
            e = np.concatenate([_core.prediction_error(tf, noise[out], Y[a:b, i], U[a:b]) for a, b in st.spans()])
            sim = np.concatenate([_core.predict_output(tf, noise[out], Y[a:b, i], U[a:b], 0) for a, b in st.spans()])
            fits.append(OutputFit(out, na, best.bic, float(_core.fit_percent(Y[:, i], Y[:, i] - e)),
                                  float(_core.fit_percent(Y[:, i], sim)), count,
                                  {1: "direct", -1: "reverse", 0: "none"}[action], cls.name, root,
                                  *((oscillation.period * ts, oscillation.amplitude) if oscillation else (None, None)),
                                  _settling_alternative(fitted, cls)))
    model = _core.Model(name or "identified from data", ts, inputs, outputs, process, noise)
    return IdentificationResult(model, ts, n, len(data) - n, summaries, fits, interpolated_samples=int(bridged.sum()))


@dataclass(frozen=True)
class _OutputSearch:
    """What every class fit of one output shares: the output and its inputs, the sample time,
    the gain's significance level, the delay range and orders searched, the thread pool and
    the stretches."""
    out: str
    inputs: list
    ts: float
    z: float
    min_delay: int
    max_delay: int
    na_orders: tuple
    numerator_lengths: tuple
    pool: object
    st: Stretches

    def fit(self, y, U, cls: ProcessClass, action: int) -> tuple["_ClassFit", int]:
        """Class ``cls`` fitted (``_search``): (the fit, the candidate models fitted).
        NotIdentified when no candidate could be fitted."""
        best, profile, n_fitted = _search(y, U, cls, self.min_delay, self.max_delay, self.na_orders,
                                          self.numerator_lengths, self.max_delay + max(self.na_orders), self.pool,
                                          self.st)
        chans = [_summarise(self.out, self.inputs[j], best, j, profile, self.ts, self.z, cls)
                 for j in range(U.shape[1])]
        return _ClassFit(cls, best, chans, action), n_fitted


def _classes_fitted(y, U, classes, action: int, search: _OutputSearch) -> tuple[list["_ClassFit"], int]:
    """Every process class of ``classes`` fitted (``_OutputSearch.fit``): (the fits, the number
    of candidate models fitted)."""
    fitted, count = [], 0
    for cls in classes:
        if cls is INTEGRATING_LAG and not _lag_worth_searching(fitted):
            continue
        try:
            fit, n_fitted = search.fit(y, U, cls, action)
        except NotIdentified:
            continue
        count += n_fitted
        fitted.append(fit)
    return fitted, count


@dataclass
class _OutputChoice:
    """One output's model: the classes fitted, the chosen class's fit with its disturbance's
    moving-average root, and the candidate models fitted."""
    fitted: list
    fit: "_ClassFit"
    root: float
    count: int

    @property
    def criterion(self) -> float:
        """The chosen fit's BIC, its moving-average root charged one parameter."""
        return self.fit.best.bic + (math.log(self.fit.best.rows) if self.root else 0.0)


def _output_fit(y, U, classes, action: int, search: _OutputSearch, duration_s: float) -> _OutputChoice | None:
    """Every class fitted, the class chosen (``_choose_class``) and its disturbance's
    moving-average root (``_moving_average_root``); None when no class could be fitted."""
    fitted, count = _classes_fitted(y, U, classes, action, search)
    if not fitted:
        return None
    cls, best, chans = _choose_class(fitted, duration_s, search.ts)
    root, fit, n_fitted = _moving_average_root(y, U, _ClassFit(cls, best, chans, action), search)
    return _OutputChoice(fitted, fit, root, count + n_fitted)


@dataclass
class _ExternalOscillation:
    """A sinusoidal disturbance set apart: the output's fit without it, its period (samples) and
    its amplitude in y."""
    choice: _OutputChoice
    period: float
    amplitude: float

    def describe(self, ts: float) -> str:
        return (f"an oscillation from outside the loop (period {self.period * ts:.4g} s, amplitude "
                f"{self.amplitude:.3g}) was set apart")


def _external_oscillation(y, U, rows, chosen: _OutputChoice, classes, action: int, search: _OutputSearch,
                          duration_s: float) -> _ExternalOscillation | None:
    """The output refitted with a sinusoid at its periodogram's peak set apart from y and U
    (``periodic_disturbance``), kept when its BIC, charged OSCILLATION_PARAMS, is lower by
    OSCILLATION_MARGIN, even when what is left identifies nothing: a channel identified only
    through the oscillation is the cycle fitted as a process (the stiction study's level loop
    with a load and an external sinusoid: a gain of the wrong sign 524 s late, 87 BIC units
    behind the fit without the sinusoid, which identifies no channel). Tried only when the
    sinusoid alone explains enough of y to pay its parameters (the search doubles the cost)."""
    frequency = dominant_frequency(y)
    y_p, amplitude = without_sinusoid(y, rows, frequency)
    n = len(y)
    if not n * math.log(np.var(y) / np.var(y_p)) > OSCILLATION_PARAMS * math.log(n):
        return None
    U_p, _ = without_sinusoid(U, rows, frequency)
    other = _output_fit(y_p, U_p, classes, action, search, duration_s)
    if other is None:
        return None
    if not other.criterion + OSCILLATION_PARAMS * math.log(other.fit.best.rows) < chosen.criterion - OSCILLATION_MARGIN:
        return None
    return _ExternalOscillation(other, 1.0 / frequency, float(amplitude[0]))


def _disturbance_with_oscillation(row: dict, cls: ProcessClass, root: float, y, U, search: _OutputSearch):
    """(na, the model file's noise denominator) for the output's channels ``row`` (input name ->
    transfer function, those the model file keeps) fitted with a sinusoid set apart: the AR of
    the output error y - G u on the data as they are, cycle included (in the class's noise
    domain, through the moving-average root), its order by BIC up to two beyond the orders
    searched (a cycle is a pair of poles). The model file has no place for a
    sinusoid, and with the cycle-free H of the projected fit `diagnose` on the same record read
    the cycle as process changes (the stiction study's flow loop with an external sinusoid,
    seeds 12-19: time-constant, delay and noise-change findings on 6 of 6; with this H, 3 of 6;
    with the cycle as a pole pair of H at radius 0.999, 6 of 6; measured while a self-regulating
    output's H still got the integrating classes' differencing, docs/identify.md)."""
    from .disturbance import bic_ar   # disturbance builds on this module

    st = search.st
    v = y - sum(st.filter(g, U[:, search.inputs.index(name)]) for name, g in row.items())
    integrates = cls.integrating and cls.noise_integrates   # the noise domain of _output_domain
    if integrates:
        v = st.filter(_core.TransferFunction(np.array([1.0, -1.0]), np.ones(1), 0), v)
    if root:
        v = st.filter(_core.TransferFunction(np.ones(1), np.array([1.0, -root]), 0), v)
    # each stretch's start-up (filters from rest) is left out, as in the search's criterion
    v[~st.after(search.max_delay + max(search.na_orders))] = np.nan
    order = max(search.na_orders) + 2
    p, poly, _, _ = bic_ar(v, order, len(v), order)
    return p, (np.convolve(poly, [1.0, -1.0]) if integrates else poly)


def _moving_average_root(y, U, chosen: "_ClassFit", search: _OutputSearch) -> tuple[float, "_ClassFit", int]:
    """The disturbance model's moving-average root for the chosen class: (root, its fit,
    candidate models fitted). Each root of MA_ROOTS refits the class on the data through
    1 / (1 - root q^-1) (H = (1 - root q^-1) / A); one wins by BIC (charged one parameter) when
    the fit still identifies the channel. The class is chosen with root 0 first: with the root
    free, slow loops in routine operation (no setpoint steps, 2 h) that an integrating class
    reads best went first order with gains 50 % off (studies/identify_study.py, pressure
    routine: 10 of 20 records). Not for an integrating class: its disturbance model already
    integrates, and a root beside it moved the rate gains of those slow routine loops read as
    integrating from 0.7-1.3 to up to 6.9 times the truth's K / tau."""
    best, root, count = chosen, 0.0, 0
    if chosen.cls.integrating:
        return root, best, count
    st, cost = search.st, chosen.best.bic
    for r in MA_ROOTS[1:]:
        smooth = _core.TransferFunction(np.ones(1), np.array([1.0, -r]), 0)
        try:
            fit, n_fitted = search.fit(st.filter(smooth, y), st.filter_columns(smooth, U), chosen.cls, chosen.action)
        except NotIdentified:
            continue
        count += n_fitted
        trial = fit.best.bic + math.log(fit.best.rows)
        if trial < cost and (fit.identified or not chosen.identified):
            best, root, cost = fit, r, trial
    return root, best, count


@dataclass
class _ClassFit:
    cls: ProcessClass
    best: "_Candidate"
    channels: list[ChannelSummary]
    action: int = 0              # the controller's action the data show (SISO), 0 when unknown

    @property
    def identified(self) -> bool:
        """A gain distinguishable from 0 that the controller's action admits: a class whose fit
        follows the feedback path (sign guard) identifies nothing, so it cannot take the place
        of another class in ``_choose_class``."""
        return any(c.significant for c in self.channels) and not _against_controller(self.channels, self.action)


def _choose_class(fitted: list[_ClassFit], duration_s: float, sample_time_s: float):
    """(class, candidate, channel summaries) of the BIC-best class, except that an integrating
    output's disturbance is an inflow (it integrates) unless the disturbance at the output scores
    better by OUTPUT_NOISE_MARGIN, and that first order plus
    dead time (the default, fitted first) gives way to another class only by a BIC better by
    CLASS_MARGIN when it identifies something; when it identifies nothing, the best identified
    other class takes its place if its BIC is lower, or if first order ran to its integrating
    boundary (every time constant longer than the record: no settling seen, the gain lost in the
    trade-off with tau), or if its every channel has a dead time of a sample or more: a rate the
    data determine, through a transport delay of its own, is an integrating loop whose first-order
    fit lost its gain to a pole near 1 (level loops with a sticking valve, tuning flow and level
    loops of studies/stiction_benchmark.py: 5 of 6 refused before), while an integrator without
    dead time is how a fast self-regulating loop under integral control can look (the tuning
    linear flow loops: rate gain 1.3 per sample, dead time 0; still refused).
    Without excitation a PI loop's one-step errors hardly tell the classes
    apart (the noise model absorbs the difference: routine data of a flow loop fit an integrator
    with theta = 0 within a BIC of 3 on 3 of 20 seeds)."""
    inflow = [f.best.bic for f in fitted if f.cls.integrating and f.cls.noise_integrates and f.identified]
    if inflow:
        fitted = [f for f in fitted if f.cls.noise_integrates or f.best.bic < min(inflow) - OUTPUT_NOISE_MARGIN]
    default, best = fitted[0], min(fitted, key=lambda f: f.best.bic)
    if default.cls is not SELF_REGULATING:
        return best.cls, best.best, best.channels
    if default.identified:
        if best is not default and best.best.bic > default.best.bic - CLASS_MARGIN:
            best = default
    else:
        others = [f for f in fitted[1:] if f.identified]
        at_boundary = all(c.time_constant_s > duration_s for c in default.channels)
        delayed = [f for f in others if all(c.dead_time_s >= sample_time_s for c in f.channels if c.significant)]
        if others and (at_boundary or min(f.best.bic for f in others) < default.best.bic):
            best = min(others, key=lambda f: f.best.bic)
        elif delayed:
            best = min(delayed, key=lambda f: f.best.bic)
    return best.cls, best.best, best.channels


def _lag_worth_searching(fitted: list[_ClassFit]) -> bool:
    """Whether to search the integrator with a lag: not when the pure integrator trails first order
    by more than PRUNE. First order reaches the pure integrator as tau -> infinity, and neither
    has a second lag, so a lagged integrator leaves the two close; a wide gap says the output
    settles, which a lag on an integrator cannot make up."""
    bic = {f.cls: f.best.bic for f in fitted}
    return not (SELF_REGULATING in bic and INTEGRATING in bic and bic[INTEGRATING] > bic[SELF_REGULATING] + PRUNE)


def _integrating_alternative(fitted: list[_ClassFit], chosen: ProcessClass) -> str:
    """For a refusal: what an identified integrating class would say, when the data leave the
    class open (a slow lag and an integrator look alike in a short closed-loop record)."""
    others = [f for f in fitted if f.cls.integrating and f.cls is not chosen and f.identified]
    if chosen.integrating or not others:
        return ""
    chans = [c for c in min(others, key=lambda f: f.best.bic).channels if c.significant]
    return ("; as an integrating process: "
            + ", ".join(f"rate gain {c.gain:.3g} +- {c.gain_sd:.2g} per s from {c.input!r}, dead time "
                        f"{c.dead_time_s:.3g} s" for c in chans)
            + " (--process integrating writes that model)")


def _settling_alternative(fitted: list[_ClassFit], chosen: ProcessClass) -> str | None:
    """For an integrating class chosen: what first order plus dead time reads when it fits the
    data better by CLASS_MARGIN or more and was passed over because it identifies nothing
    (``_choose_class``). In a short closed-loop record a slow settling process and an integrator
    look alike; the integrator's rate can be firm where first order's gain is not, yet the
    one-step errors favour settling. Routine pressure-like PI loops (tau 120 s, 2 h at 10 s,
    studies/identify_study.py seeds 1-4) were called integrating with first order better by 12-17
    (gain -2.85 +- 1.4 for a true -2.5) and a simulation fit of -354 % to -940 %. Taking first
    order there instead also refused true levels of the stiction study, and first order fits
    better by CLASS_MARGIN on many true levels with a sticking valve (docs/identify.md "When the
    class is open"), so the choice stays and the summary says the class is open."""
    first = next((f for f in fitted if f.cls is SELF_REGULATING), None)
    taken = next((f for f in fitted if f.cls is chosen), None)
    if not chosen.integrating or first is None or taken is None:
        return None
    margin = taken.best.bic - first.best.bic
    if not margin >= CLASS_MARGIN:
        return None
    return (f"first order plus dead time fits these data better by {margin:.1f} in BIC but does not determine "
            "its gain (" + ", ".join(f"{c.gain:.3g} +- {c.gain_sd:.2g} from {c.input!r}, time constant "
                                      f"{c.time_constant_s:.3g} s" for c in first.channels)
            + "); over this record a slow settling process and an integrator look alike "
            "(--process self-regulating tries that class)")


@dataclass
class _Candidate:
    bic: float
    cost: float                  # mean squared one-step error over the common range
    a: np.ndarray                # a_1..a_na
    delays: list[int]
    nb: list[int]
    nf: int                      # denominator order of every channel (ProcessClass.nf)
    tf: list                     # TransferFunction per input, in the fitted domain
    theta: np.ndarray            # OE parameters [b_1 f_1 b_2 f_2 ...] per channel
    rows: int                    # length of the common range
    covariance: np.ndarray | None = None  # of [theta, a] (``_joint_covariance``), for the chosen one


def _output_domain(c: _Candidate, cls: ProcessClass):
    """c's channels and noise denominator as the model of y: for an integrating output
    G = G' / (1 - q^-1), and H = 1 / (A (1 - q^-1)) when the disturbance integrates too."""
    if not cls.integrating:
        return list(c.tf), np.r_[1.0, c.a]
    return ([_core.TransferFunction(np.asarray(g.num), np.convolve(g.den, [1.0, -1.0]), g.delay) for g in c.tf],
            np.convolve(np.r_[1.0, c.a], [1.0, -1.0]) if cls.noise_integrates else np.r_[1.0, c.a])


def _integrated(U: np.ndarray, st: Stretches) -> np.ndarray:
    """u / (1 - q^-1) per input (running sums of the deviations from the mean), each stretch's
    mean removed: the level the inflows alone would give, around y's mean in that stretch (what
    flowed in during a gap is unknown)."""
    return st.demeaned(st.cumsum(U))


def _differenced(y: np.ndarray, st: Stretches) -> np.ndarray:
    """(1 - q^-1) y with mean removed, on y's rows (each stretch's first is 0 before the mean's
    removal)."""
    dy = st.differenced(y)
    return dy - dy.mean()


def _sweep(y, U, cls: ProcessClass, na, min_delay, max_delay, numerator_lengths, t0, st: Stretches):
    """Coordinate search at noise order na over each channel's (delay, numerator length) by
    ARX-OE: (the BIC-best candidate refined to the joint fit, or None when none could be fitted;
    every candidate fitted as (channel, candidate); the number of fits)."""
    m = U.shape[1]
    delays, nb = [min_delay] * m, [1] * m
    current, tried, count = None, [], 0
    for _round in range(1 if m == 1 else 2):
        for j in range(m):
            for d in range(min_delay, max_delay + 1):
                for k in numerator_lengths:
                    trial_d, trial_nb = list(delays), list(nb)
                    trial_d[j], trial_nb[j] = d, k
                    c = _fit(y, U, na, trial_d, trial_nb, cls, t0, st)
                    count += 1
                    if c is None:
                        continue
                    tried.append((j, c))
                    if current is None or c.bic < current.bic:
                        current = c
            if current is not None:
                delays, nb = list(current.delays), list(current.nb)
    return (None if current is None else _refine(y, U, current, cls, t0, st)), tried, count


def _search(y, U, cls: ProcessClass, min_delay, max_delay, na_orders, numerator_lengths, t0, pool=None,
            st: Stretches | None = None):
    """``_sweep`` for every na over the stretches ``st`` (default: the rows are one stretch), in
    cls's domain (y differenced for an integrating output), on
    ``pool``'s threads when given (the ARX-OE fits release the GIL; each sweep is independent, so
    the result does not depend on the threads). The BIC-best na is kept; at that na every
    candidate not clearly worse (PRUNE) is refined too, and the BIC-best refined candidate
    returned with the profile {(channel, dead time in samples): refined cost, inf for pruned ones}
    and the number of candidates fitted."""
    m = U.shape[1]
    st = st or Stretches([len(y)])
    if cls.integrating and cls.noise_integrates:
        # mean removed: a constant inflow imbalance (OP's mean is not the balancing flow)
        y = _differenced(y, st)
    elif cls.integrating:
        y, U = st.demeaned(y), _integrated(U, st)
    sweeps = list((pool.map if pool else map)(
        lambda na: _sweep(y, U, cls, na, min_delay, max_delay, numerator_lengths, t0, st), na_orders))
    finalists = [s[0] for s in sweeps if s[0] is not None]
    tried = {na: s[1] for na, s in zip(na_orders, sweeps)}
    count = sum(s[2] for s in sweeps)
    if not finalists:
        raise NotIdentified("not identified: no candidate model could be fitted (data not informative)")
    best = min(finalists, key=lambda c: c.bic)
    profile = {}
    for j, c in tried[len(best.a)]:
        if c.rows * np.log(c.cost / best.cost) <= PRUNE:
            c = _refine(y, U, c, cls, t0, st)
            if c.bic < best.bic:
                best = c
            cost = c.cost
        else:
            cost = np.inf
        where = (j, _dead_time_samples(c, j, cls))
        profile[where] = min(profile.get(where, np.inf), cost)
    for j in range(m):
        where = (j, _dead_time_samples(best, j, cls))
        profile[where] = min(profile.get(where, np.inf), best.cost)
    best.covariance = _joint_covariance(y, U, best, st)
    return best, profile, count


def _joint_covariance(y, U, c: _Candidate, st: Stretches | None = None) -> np.ndarray:
    """sigma^2 (J'J)^-1 of all parameters [b_1 f_1 ... b_m f_m, a_1..a_na] of the joint fit,
    eps = A (y - sum_j B_j / F_j q^-d_j u_j) over t >= na. Under feedback the estimates of G
    and H are correlated, so the OE covariance (A held fixed) would understate G's spread.
    Sensitivities: d eps / d b_jk = -A q^-k w_j with w_j = q^-d_j u_j / F_j,
    d eps / d f_j1 = A q^-1 x_j / F_j with x_j = G_j u_j, d eps / d a_i = q^-i v, v = y - sum x_j.
    Over the stretches ``st`` (default: one), each from rest."""
    st = st or Stretches([len(y)])
    na = len(c.a)
    A = _core.TransferFunction(np.r_[1.0, c.a], np.ones(1), 0)
    x = [st.filter(g, U[:, j]) for j, g in enumerate(c.tf)]
    v = y - sum(x)
    cols = []
    for j, g in enumerate(c.tf):
        inv_f = _core.TransferFunction(np.ones(1), np.asarray(g.den), 0)
        w = st.filter(_core.TransferFunction(np.ones(1), np.asarray(g.den), g.delay), U[:, j])
        aw = st.filter(A, w)
        cols += [-st.lag(aw, k) for k in range(c.nb[j])]
        if c.nf:
            cols.append(st.lag(st.filter(A, st.filter(inv_f, x[j])), 1))
    cols += [st.lag(v, i) for i in range(1, na + 1)]
    rows = st.after(na)
    J = np.column_stack(cols)[rows]
    eps = st.filter(A, v)[rows]
    sigma2 = eps @ eps / max(len(eps) - J.shape[1], 1)
    return sigma2 * np.linalg.pinv(J.T @ J)


def _fit(y, U, na, delays, nb, cls, t0, st: Stretches | None = None):
    """One candidate by ARX-OE over the stretches ``st`` (default: one), or None when it is not
    informative or not of cls's form."""
    st = st or Stretches([len(y)])
    try:
        r = arx_oe(y, U, na, na + 1, delays, structure="oe", oe_nb=nb, oe_nf=cls.nf, fir_length=1,
                   detrend="none", stretch_starts=st.starts)
    except RuntimeError:
        return None
    return _candidate(y, U, np.asarray(r.noise), delays, nb, cls, r.oe, t0, st)


def _candidate(y, U, a, delays, nb, cls, oe_result, t0, st: Stretches):
    tf = []
    for j, d in enumerate(delays):
        b, f = np.asarray(oe_result.b[j]), np.asarray(oe_result.f[j])
        if _continuous(b, f, d, 1.0, cls) is None:
            return None
        tf.append(_core.TransferFunction(b, f, d))
    inverse_noise = _core.TransferFunction(np.r_[1.0, a], np.ones(1), 0)
    e = y - sum(st.filter(g, U[:, j]) for j, g in enumerate(tf))
    e = st.filter(inverse_noise, e)[st.after(t0)]
    cost = float(np.mean(e**2))
    # per channel K, theta (and tau): the dead time is one continuous parameter whether it falls
    # on a sample (one numerator term) or between two (two terms, docs/formats.md's ZOH form);
    # counting b1 as an extra parameter made BIC round a fractional dead time down to the sample
    # and tau absorb the rest
    n, k = len(e), len(a) + cls.parameters * len(nb)
    return _Candidate(n * np.log(cost) + k * np.log(n), cost, a, list(delays), list(nb), cls.nf, tf,
                      np.asarray(oe_result.theta), n)


def _refine(y, U, c: _Candidate, cls, t0, st: Stretches | None = None, max_iterations=200, tolerance=1e-12):
    """The joint prediction-error fit of G and H = 1/A for c's structure, by alternating the two
    least-squares problems it splits into: A given G (an AR fit of v = y - G u) and G given A
    (the OE fit on A-filtered data), both over t >= na. Each step lowers sum (A (y - G u))^2,
    so the ARX step's A, biased when the ARX orders are low, no longer biases G. Stops when a
    step lowers that sum by less than ``tolerance`` (relative) or fails. Over the stretches
    ``st`` (default: one), each from rest."""
    st = st or Stretches([len(y)])
    na = len(c.a)
    rows = st.after(na)
    best, level = c, np.inf
    for _ in range(max_iterations):
        v = y - sum(st.filter(g, U[:, j]) for j, g in enumerate(best.tf))
        lagged = np.column_stack([-st.lag(v, i + 1) for i in range(na)])
        a = np.linalg.lstsq(lagged[rows], v[rows], rcond=None)[0]
        A = _core.TransferFunction(np.r_[1.0, a], np.ones(1), 0)
        yf = st.filter(A, y)
        uf = st.filter_columns(A, U)
        try:
            r = oe(yf, uf, best.delays, structure="oe", nb=best.nb, nf=cls.nf, skip=na,
                   stretch_starts=st.starts)
        except RuntimeError:
            return best
        trial = _candidate(y, U, a, best.delays, best.nb, cls, r, t0, st)
        if trial is None or not r.cost < level:
            return best
        best, done = trial, r.cost > level * (1 - tolerance)
        level = r.cost
        if done:
            break
    return best


def _continuous(b, f, delay, ts, cls: ProcessClass):
    """(K, tau, theta) of a fitted channel of class cls, or None when it is not of that form."""
    return (integrating_reading if cls.integrating else _foptd)(b, f, delay, ts)


def _foptd(b, f, delay, ts):
    """(K, tau, theta) of G = q^-delay (b0 + b1 q^-1) / (1 + f1 q^-1), the inverse of the ZOH
    discretisation (docs/formats.md); None when G is not of that form (pole outside (0, 1) is allowed
    down to 0: tau below the sample resolution; b1 / (b0 + b1) outside [0, 1) is not a dead time)."""
    a = -f[1]
    if not (a < 1.0) or b.sum() == 0.0:
        return None
    gain = b.sum() / (1.0 - a)
    tau = -ts / np.log(a) if a > 0 else 0.0
    share = b[1] / b.sum() if len(b) > 1 else 0.0
    if not (-1e-9 <= share < 1.0):
        return None
    if len(b) > 1 and 0 < a:
        frac = 1.0 - np.log(a + (1.0 - a) * share) / np.log(a)
    else:
        frac = share  # a pure gain: the dead time splits linearly between the two samples
    return gain, tau, (delay - 1 + frac) * ts


def _dead_time_samples(c: _Candidate, j: int, cls: ProcessClass) -> float:
    b, f = _channel_params(c, j)
    return _continuous(b, f, c.delays[j], 1.0, cls)[2]


def _channel_params(c: _Candidate, j: int):
    k = sum(nb + c.nf for nb in c.nb[:j])
    nb = c.nb[j]
    return c.theta[k:k + nb], np.r_[1.0, c.theta[k + nb:k + nb + c.nf]]


def significance_z(dead_times: int) -> float:
    """|K| / sd(K) a gain needs to count as an effect at 5 %: the best of ``dead_times`` searched
    delays is the largest of that many chances, hence the Bonferroni level 0.05 / dead_times."""
    return NormalDist().inv_cdf(1.0 - 0.025 / max(dead_times, 1))


def _summarise(out, inp, c: _Candidate, j: int, profile, ts, z_effect, cls: ProcessClass) -> ChannelSummary:
    b, f = _channel_params(c, j)
    gain, tau, dead = _continuous(b, f, c.delays[j], ts, cls)
    k = sum(nb + c.nf for nb in c.nb[:j])
    nb = c.nb[j]
    idx = slice(k, k + nb + c.nf)
    cov = c.covariance[idx, idx]
    p = np.r_[b, f[1:]]

    def value(q, which):
        return _continuous(q[:nb], np.r_[1.0, q[nb:]], c.delays[j], ts, cls)[which]

    gain_sd = _delta_sd(lambda q: value(q, 0), p, cov)
    tau_sd = _delta_sd(lambda q: value(q, 1), p, cov) if tau > 0 else float("nan")
    lo, hi = _profile_interval({s: v for (jj, s), v in profile.items() if jj == j}, c.rows)
    return ChannelSummary(out, inp, float(gain), float(gain_sd), float(tau), float(tau_sd), float(dead),
                          (float(lo * ts), float(hi * ts)), int(c.delays[j]), int(c.nb[j]),
                          bool(abs(gain) >= z_effect * gain_sd), cls.integrating,
                          _has_effect(b, cov[:nb, :nb], z_effect))


def _has_effect(b: np.ndarray, cov_b: np.ndarray, z_effect: float) -> bool:
    """Whether the channel moves the output at all: the Wald test of b = 0 (G = 0 exactly when its
    numerator is 0) at the search-corrected level of ``significance_z``, chi-square with one
    degree of freedom per numerator term. The gain K = B(1) / F(1) is then tested on its own at
    95 %: once the search has found an effect, its steady state is one question, not one per
    dead time. Testing K alone at the search-corrected level refused sticking flow valves whose
    numerator was determined beyond doubt (Wald 120-240 against a threshold of 14) while the
    gain, traded off against a slow pole, was 2-3 standard deviations from 0."""
    try:
        wald = float(b @ np.linalg.solve(cov_b, b))
    except np.linalg.LinAlgError:
        return False
    return _chi2_sf(wald, len(b)) <= 2.0 * (1.0 - NormalDist().cdf(z_effect))


def _chi2_sf(x: float, dof: int) -> float:
    """P(chi-square(dof) > x), exact for integer dof: erfc for one degree of freedom, exp for two,
    then sf(x; k + 2) = sf(x; k) + (x/2)^(k/2) e^(-x/2) / Gamma(k/2 + 1)."""
    if x <= 0:
        return 1.0
    k, sf = (1, math.erfc(math.sqrt(x / 2.0))) if dof % 2 else (2, math.exp(-x / 2.0))
    while k < dof:
        sf += math.exp((k / 2.0) * math.log(x / 2.0) - x / 2.0 - math.lgamma(k / 2.0 + 1.0))
        k += 2
    return sf


def _profile_interval(cost_at: dict, rows: int) -> tuple[float, float]:
    """95 % likelihood-ratio interval of the dead time (samples) from its profile: the dead times
    with n log(V / V_best) <= chi2_1(95 %), widened to the nearest searched dead time outside
    on each side (the profile is known only at the searched points; the boundary lies between)."""
    points = sorted(cost_at)
    best = min(cost_at.values())
    inside = [i for i, s in enumerate(points) if rows * np.log(cost_at[s] / best) <= CHI2_1_95]
    return points[max(inside[0] - 1, 0)], points[min(inside[-1] + 1, len(points) - 1)]


def _delta_sd(fn, p, cov) -> float:
    """sqrt(g' C g) with g the central-difference gradient of fn at p."""
    g = np.empty(len(p))
    for i in range(len(p)):
        h = 1e-6 * max(abs(p[i]), 1e-3)
        up, down = p.copy(), p.copy()
        up[i] += h
        down[i] -= h
        try:
            g[i] = (fn(up) - fn(down)) / (2 * h)
        except TypeError:  # fn left the FOPTD form within h: the spread is not defined
            return float("nan")
    return float(np.sqrt(max(g @ cov @ g, 0.0)))


def _check_verdict(out, chans, action) -> None:
    if not any(c.kept for c in chans):
        worst = chans[0]
        raise NotIdentified(f"not identified: no input explains {out!r} (gain of {worst.input!r} "
                            f"{worst.gain:.3g} +- {worst.gain_sd:.2g}: not distinguishable from 0; "
                            "the data lack excitation, e.g. setpoint steps)")
    if _against_controller(chans, action):
        c = chans[0]
        raise NotIdentified(
            f"not identified: the gain of {out!r} <- {c.input!r} ({c.gain:.3g} +- {c.gain_sd:.2g}) "
            f"has the sign opposite to the controller's action ({'direct' if action > 0 else 'reverse'}),"
            f" without overwhelming evidence (|K| / sd < {SIGN_FLIP_Z:g}); the fit follows the feedback path")


def _against_controller(chans, action) -> bool:
    """A single loop's gain of the sign opposite to the controller's action without overwhelming
    evidence (|K| / sd < SIGN_FLIP_Z): a stable loop needs the controller's sign."""
    if not action or len(chans) != 1:
        return False
    c = chans[0]
    return bool(np.sign(c.gain) != action and abs(c.gain) < SIGN_FLIP_Z * c.gain_sd)


def _controller_action(u, pv, sp, starts=()) -> int:
    """The feedback sign the data show from pv to the input u: +1 when the input moves with the control error
    sp - pv (the controller needs a positive process gain), -1 against it, 0 when no feedback
    shows. From the velocity form of a PI controller, du(t) = kc de(t) + ki e(t) (lag 0
    included: that is where the controller acts), by least squares with a 99.9 % t test on
    the proportional and integral terms together (they share the controller's sign).
    ``starts``: rows where a new stretch begins (rows laid end to end across gaps); the
    differences across them are left out."""
    e = (np.nanmean(pv) if sp is None else sp) - pv
    if not np.all(np.isfinite(e)):
        e = np.where(np.isfinite(e), e, np.nanmean(e))
    within = np.ones(len(u) - 1, dtype=bool)
    within[np.asarray(starts, dtype=int) - 1] = False
    du, de, e = np.diff(u)[within], np.diff(e)[within], e[1:][within]
    X = np.column_stack([de, e - e.mean(), np.ones(len(du))])
    coef, *_ = np.linalg.lstsq(X, du, rcond=None)
    resid = du - X @ coef
    dof = max(len(du) - 3, 1)
    cov = np.linalg.pinv(X.T @ X) * (resid @ resid / dof)
    # the sign-weighted sum kc/sd_kc + ki/sd_ki: both terms vote, the better determined more
    z = [coef[i] / np.sqrt(cov[i, i]) if cov[i, i] > 0 else 0.0 for i in (0, 1)]
    total = (z[0] + z[1]) / np.sqrt(2.0)
    return int(np.sign(total)) if abs(total) > 3.29 else 0


def _controller_law_exact(u, pv, sp) -> bool:
    """Whether u is exactly a PID law of pv with nothing else moving it: the setpoint constant
    (or not given) and du(t) a linear function of e(t), e(t-1), e(t-2) (e = sp - pv) to rounding.
    A controller run at the sample rate on a record without setpoint moves: its OP carries no
    information the PV lags do not, the ARX regressors of the short dead times are collinear with
    the law, and the direct method's estimate is not determined by the data (the stiction study's
    flow loop, gain 1: gains of 0.24-0.30 came out, each as +- 15 %). A real controller scans
    faster than the historian samples, so its law is not exact at 10 s and this stays False."""
    if sp is not None and np.ptp(sp[np.isfinite(sp)]) > 0:
        return False
    e = -np.asarray(pv, dtype=float)   # sp - pv up to the constant setpoint, which the constant absorbs
    u = np.asarray(u, dtype=float)
    if not (np.all(np.isfinite(e)) and np.all(np.isfinite(u))) or len(u) < 10:
        return False
    du = np.diff(u)[1:]
    if not np.any(du):
        return False
    X = np.column_stack([e[2:], e[1:-1], e[:-2], np.ones(len(du))])
    coef, *_ = np.linalg.lstsq(X, du, rcond=None)
    return bool(np.sqrt(np.mean((du - X @ coef) ** 2)) <= 1e-6 * np.sqrt(np.mean(du**2)))


def _stable_monic(den: np.ndarray) -> np.ndarray:
    """den with roots outside the unit circle reflected inside (same spectrum up to scale; the
    model file needs a stable, inversely stable H = 1 / den) and radius capped at 0.999."""
    roots = np.roots(den)
    if len(roots) == 0 or np.all(np.abs(roots) < 0.999):
        return den
    roots = np.where(np.abs(roots) > 1.0, 1.0 / np.conj(roots), roots)
    roots = np.where(np.abs(roots) > 0.999, roots * 0.999 / np.abs(roots), roots)
    return np.real(np.poly(roots))


def loop_columns(inputs, outputs, setpoints=None) -> tuple[list[str], list[str], list[str] | None]:
    """The column names of ``inputs``, ``outputs`` and ``setpoints`` (one per output, or None)
    as lists (each a list or a comma-separated text); ValueError on a name given twice, as both
    input and output, or a setpoint count that does not match."""
    inputs, outputs = _names(inputs, "inputs"), _names(outputs, "outputs")
    both = set(inputs) & set(outputs)
    if both:
        raise ValueError(f"column(s) {sorted(both)} given as both input and output")
    if setpoints is not None:
        setpoints = _names(setpoints, "setpoints")
        if len(setpoints) != len(outputs):
            raise ValueError(f"setpoints: give one per output ({len(outputs)}), got {len(setpoints)}")
    return inputs, outputs, setpoints


def _names(names, what) -> list[str]:
    if isinstance(names, str):
        names = [n.strip() for n in names.split(",")]
    names = [str(n) for n in names if str(n)]
    if not names:
        raise ValueError(f"{what}: give at least one column name")
    if len(set(names)) != len(names):
        raise ValueError(f"{what}: a column is named twice ({', '.join(names)})")
    return names

