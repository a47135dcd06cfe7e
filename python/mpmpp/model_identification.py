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
unless an integrating one wins clearly (``class_choice``).

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

import numpy as np

from . import _core
from .channel_reading import SIGN_FLIP_Z, ChannelSummary, against_controller, significance_z, summarise
from .class_choice import ClassFit, choose_class, integrating_alternative, lag_worth_searching, settling_alternative
from .controller_action import controller_action, controller_law_exact
from .held_values import frozen, require_computable
from .io import json_safe
from .periodic_disturbance import dominant_frequency, without_sinusoid
from .process_class import INTEGRATING_LAG, PROCESS_CLASSES, SELF_REGULATING, ProcessClass
from .record_length import MIN_ROWS, require_rows
from .signals import bridge_lost_outputs, complete_runs, missing_counts
from .stretches import Stretches
from .structure_search import NotIdentified, output_domain, search_structure
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
# A sinusoidal disturbance set apart (_external_oscillation) costs its amplitude, phase and
# frequency, and must then win by "very strong" evidence (Kass & Raftery), the frequency being the
# best of a search. Chosen a priori; on the stiction study's tuning loops (flow, level, level with
# a load, temperature; seeds 7001-7004, 112 records) the loops with an external sinusoid won by
# 15-68 and the others by at most 6.9 (a sticking level valve), 2.1 and 1.1.
OSCILLATION_PARAMS = 3
OSCILLATION_MARGIN = 10.0
DEFAULT_MAX_DEAD_TIME_S = 600.0


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
    # or more (``settling_alternative``): what first order reads; None otherwise
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
            actions = [controller_action(U[:, j], raw[:, len(inputs) + i], sp[out], st.starts)
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
                c.unexcited = all(controller_law_exact(U[a:b, j], raw[a:b, len(inputs) + i],
                                                       None if sp[out] is None else sp[out][a:b])
                                  for a, b in st.spans())
            try:
                _check_verdict(out, chans, action)
            except NotIdentified as refusal:
                raise NotIdentified(str(refusal) + integrating_alternative(fitted, cls)
                                    + (f"; {oscillation.describe(ts)} first, and what is left does not identify "
                                       "the loop" if oscillation else "")) from None
            tf, a = output_domain(best, cls)
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
                                  settling_alternative(fitted, cls)))
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

    def fit(self, y, U, cls: ProcessClass, action: int) -> tuple[ClassFit, int]:
        """Class ``cls`` fitted (``search_structure``): (the fit, the candidate models fitted).
        NotIdentified when no candidate could be fitted."""
        best, profile, n_fitted = search_structure(y, U, cls, self.min_delay, self.max_delay, self.na_orders,
                                                   self.numerator_lengths, self.max_delay + max(self.na_orders),
                                                   self.pool, self.st)
        chans = [summarise(self.out, self.inputs[j], best, j, profile, self.ts, self.z, cls)
                 for j in range(U.shape[1])]
        return ClassFit(cls, best, chans, action), n_fitted


def _classes_fitted(y, U, classes, action: int, search: _OutputSearch) -> tuple[list[ClassFit], int]:
    """Every process class of ``classes`` fitted (``_OutputSearch.fit``): (the fits, the number
    of candidate models fitted)."""
    fitted, count = [], 0
    for cls in classes:
        if cls is INTEGRATING_LAG and not lag_worth_searching(fitted):
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
    fit: ClassFit
    root: float
    count: int

    @property
    def criterion(self) -> float:
        """The chosen fit's BIC, its moving-average root charged one parameter."""
        return self.fit.best.bic + (math.log(self.fit.best.rows) if self.root else 0.0)


def _output_fit(y, U, classes, action: int, search: _OutputSearch, duration_s: float) -> _OutputChoice | None:
    """Every class fitted, the class chosen (``choose_class``) and its disturbance's
    moving-average root (``_moving_average_root``); None when no class could be fitted."""
    fitted, count = _classes_fitted(y, U, classes, action, search)
    if not fitted:
        return None
    cls, best, chans = choose_class(fitted, duration_s, search.ts)
    root, fit, n_fitted = _moving_average_root(y, U, ClassFit(cls, best, chans, action), search)
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
    integrates = cls.integrating and cls.noise_integrates   # the noise domain of output_domain
    if integrates:
        v = st.filter(_core.TransferFunction(np.array([1.0, -1.0]), np.ones(1), 0), v)
    if root:
        v = st.filter(_core.TransferFunction(np.ones(1), np.array([1.0, -root]), 0), v)
    # each stretch's start-up (filters from rest) is left out, as in the search's criterion
    v[~st.after(search.max_delay + max(search.na_orders))] = np.nan
    order = max(search.na_orders) + 2
    p, poly, _, _ = bic_ar(v, order, len(v), order)
    return p, (np.convolve(poly, [1.0, -1.0]) if integrates else poly)


def _moving_average_root(y, U, chosen: ClassFit, search: _OutputSearch) -> tuple[float, ClassFit, int]:
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


def _check_verdict(out, chans, action) -> None:
    if not any(c.kept for c in chans):
        worst = chans[0]
        raise NotIdentified(f"not identified: no input explains {out!r} (gain of {worst.input!r} "
                            f"{worst.gain:.3g} +- {worst.gain_sd:.2g}: not distinguishable from 0; "
                            "the data lack excitation, e.g. setpoint steps)")
    if against_controller(chans, action):
        c = chans[0]
        raise NotIdentified(
            f"not identified: the gain of {out!r} <- {c.input!r} ({c.gain:.3g} +- {c.gain_sd:.2g}) "
            f"has the sign opposite to the controller's action ({'direct' if action > 0 else 'reverse'}),"
            f" without overwhelming evidence (|K| / sd < {SIGN_FLIP_Z:g}); the fit follows the feedback path")


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

