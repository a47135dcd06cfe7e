"""Per-output residuals and their whitening: the noise side every candidate fit shares.

With v = y_i - G_i u the output error of the nominal model and e = H_i^-1 v its one-step
prediction error, a two-segment AR split of e finds where the disturbance's level or colour
changed. Each side gets its own AR correction A_s(q), so ``whiten(x) = A_s H^-1 x / sigma_s``
turns e into (nearly) white, unit-variance noise whatever the disturbance did. Whitening with a
re-estimated noise model keeps the process fits consistent in closed loop when the disturbance
changed (the direct method is biased when the noise model is wrong).

Every AR fit of the disturbance (the model estimated when the file has none, and the
corrections) is made beside a short Laguerre basis of the inputs (ARX, ``input_basis``) whose
coefficients are then dropped: fitted to the error alone, the AR absorbs the part of a process
change its own past predicts (the slow transient a tripled time constant leaves after each
setpoint step), and whitened with it the change scores a fraction of what it explains. Beside
the inputs, the AR describes the disturbance, as a high-order ARX model's noise part does in
closed loop (consistent with the direct method); the inputs' coefficients are dropped, so the
whitening cannot manufacture an input correlation.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from .. import _core
from .._core import TransferFunction
from ..integrating import row_integrates, without_line
from ..signals import Signals, bridged_reach, filtered_columns, per_segment
from .laguerre import delayed_before, laguerre_filters, laguerre_pole, output_basis
from .result import InsufficientData
from .trend import TrendScan, trend_fit

AR_ORDER = 5                 # AR correction of the noise model (residual whitening)
CORRECTION_ROOTS = (0.0, 0.5, 0.7, 0.8, 0.9, 0.95, 0.98, 0.99, 0.995)
WANDERING_POLE = 0.95        # a noise model pole this close to 1: the disturbance wanders (root_grid)
SETTLE = 60                  # samples left out after the start of each filtered segment
NOISE_ORDER = 10             # AR order of a disturbance model estimated from the data
MIN_AR_ROWS_PER_COEFFICIENT = 10
INPUT_BASIS_FUNCTIONS = 4    # Laguerre functions per input beside every disturbance AR fit
TREND_GRID = 60              # onset grid (samples) of the step + ramp removed before that fit
# The disturbance AR estimated beside the inputs is replaced by the plain AR when, alone, it
# leaves more than this many times the squared error of no AR at all (disturbance_ar).
# Measured on tuning draws: the amplifying fit of mpc_level seed 8 (exact model, no noise
# model, MPC) left 4.4 times; those of hand-written PI-loop models with a gain error, which
# the plain AR would bias (it takes up the input's part), 0.03-1.07 times.
AMPLIFYING = 2.0
# An estimated disturbance model is fitted on the first of this many parts of the record, each at
# least this many usable rows, when the record's AR is this decisively wrong there
# (first_part_ar).
REFERENCE_PARTS = 4
REFERENCE_PART_ROWS = 1500
REFERENCE_EVIDENCE = 100.0
# Unmeasured step / ramp disturbances on an output: up to this many breakpoints are fitted
# before a disturbance model or its corrections are estimated (each kept while it beats BIC).
MAX_DISTURBANCE_STEPS = 8


@dataclass
class OutputResidual:
    """Everything about one output that the candidate fits share."""

    sig: Signals = field(repr=False)
    i: int
    name: str
    v: np.ndarray = field(repr=False)            # output error y_i - G_i u
    e: np.ndarray = field(repr=False)            # one-step error H^-1 v
    weight: np.ndarray = field(repr=False)       # 1 on samples used (segments minus settling)
    split: object = field(repr=False)            # _core AR split of e (level / colour change)
    split_onset: int | None
    split_significant: bool
    pieces: list[tuple[int, int]]                # [start, stop) ranges with their own AR
    ar: list[np.ndarray] = field(repr=False)     # AR correction A_s per piece
    sigma: list[float] = field(repr=False)       # innovation RMS per piece
    r: np.ndarray = field(repr=False)            # whitened output error
    fold: list[np.ndarray] = field(repr=False)   # weights of the even / odd held-out blocks
    block: int                                   # rows per held-out block
    n: int
    noise_estimated: bool = False                # H estimated from these data, not the model's
    disturbance_onsets: list[int] = field(default_factory=list)   # step + ramp breakpoints in e
    free: np.ndarray | None = field(repr=False, default=None)      # e less those steps + ramps
    nuisance: "Nuisance | None" = field(repr=False, default=None)  # what candidates are fitted beside
    # (effect, input) of a change from the first row whose update the search dropped (process.py)
    refused: frozenset = frozenset()
    inputs: np.ndarray | None = field(repr=False, default=None)    # H^-1-filtered input basis (ARX fits)
    root: list[float] = field(default_factory=list)  # moving-average root c_s per piece (0: none)

    @property
    def row(self) -> list:
        return self.sig.rows[self.i]

    @property
    def noise(self) -> TransferFunction:
        return self.sig.noise[self.i]

    @property
    def offered_roots(self) -> tuple:
        """The moving-average roots the noise side may take (``root_grid``)."""
        return root_grid(self.noise)

    def whiten(self, x: np.ndarray) -> np.ndarray:
        """A_s H^-1 x / sigma_s per piece (filters restart at every piece)."""
        out = np.zeros_like(x, dtype=float)
        for p, (a, b) in enumerate(self.pieces):
            out[a:b] = self.whiten_piece(p, x[a:b])
        return out

    def whiten_piece(self, p: int, x: np.ndarray) -> np.ndarray:
        """A_p / (1 - c_p q^-1) H^-1 x / sigma_p for x on piece p (filters start at rest)."""
        return correction(self.ar[p], self.root[p]).filter(self.noise.inverse().filter(x)) / self.sigma[p]

    def forgetting_rows(self, p: int) -> int:
        """Rows after which piece p's whitening filter, started at rest, gives what it gives
        started earlier on the same input, to below 1e-21 of the earlier start's state (its
        free response, the powers of H^-1's largest pole, has decayed): the FIR parts' length,
        plus 50 time constants of that pole. A pole within 1e-3 of the unit circle never
        forgets within a record (the piece's length)."""
        inverse = self.noise.inverse()
        a, b = self.pieces[p]
        fir = len(inverse.num) + len(self.ar[p]) + inverse.delay
        rho = float(np.abs(np.r_[inverse.poles(), self.root[p]]).max())
        if rho >= 1.0 - 1e-3:
            return b - a
        return min(b - a, fir + (math.ceil(50.0 / -math.log(rho)) if rho > 0.0 else 0))

    def channel_response(self, g: TransferFunction, x: np.ndarray) -> np.ndarray:
        """g x per data segment (zero outside)."""
        return np.nan_to_num(per_segment(self.sig, g.filter, x))


def output_error(sig: Signals, i: int, row: list, u: np.ndarray) -> np.ndarray:
    """y_i - sum_j G_ij u_j with the channels ``row``, filtered from rest in each data segment.
    With an integrating channel in ``row`` each segment's least-squares line is taken out: an
    input away from the operating point the record's mean guesses (a level loop's OP off its
    balance) makes the integrator's error ramp, which is no model error (integrating.py)."""
    v = per_segment(sig, lambda yy, uu: _core.output_error(row, yy, uu), sig.y[:, i], u)
    return per_segment(sig, without_line, v) if row_integrates(row) else v


def used_rows(sig: Signals, i: int, hinv: TransferFunction, reach: int) -> np.ndarray:
    """Rows of output i's error that fits use: each data segment after SETTLE rows (the filters
    start at rest there), less the errors that read an interpolated sample through ``hinv`` and
    ``reach`` lags (``bridged_reach``)."""
    used = np.zeros(len(sig.time_s), bool)
    for a, b in sig.segments:
        used[a + SETTLE:b] = True
    return used & ~bridged_reach(sig, i, hinv, reach)


def disturbance_split(e: np.ndarray, weight: np.ndarray, hinv: TransferFunction, first_onset: int,
                      min_segment: int):
    """The best change of the disturbance's level or colour in the one-step error ``e`` after
    ``first_onset`` (``_core.split_ar``). A slow drift changes the AR fit too, and a split inside
    it lets each side's correction absorb a different part of it; so the split is made on e with
    its best step + ramp removed (the drift itself is a candidate of the process pool)."""
    trend = trend_fit(e, weight > 0, hinv, first_onset, 4 * min_segment // 12, max(first_onset, 2 * SETTLE)).trend
    return _core.split_ar((e - trend)[first_onset:], AR_ORDER, min_segment, max(min_segment // 60, 1))


def split_is_significant(split, n: int) -> bool:
    """Whether the split beats its parameters (AR coefficients, variance, onset)."""
    return split.statistic > (AR_ORDER + 2) * math.log(n)


def output_residual(sig: Signals, i: int, min_segment: int, first_onset: int, block: int,
                    noise_estimated: bool = False) -> OutputResidual:
    """Residuals of output i, its disturbance split and whitening, and the held-out blocks
    (even / odd blocks of ``block`` samples)."""
    n = len(sig.time_s)
    row, noise = sig.rows[i], sig.noise[i]
    v = output_error(sig, i, row, sig.u)
    e = per_segment(sig, lambda vv: noise.inverse().filter(vv), v)
    weight = used_rows(sig, i, noise.inverse(), AR_ORDER).astype(float)
    e0 = np.nan_to_num(e)
    split = disturbance_split(e0, weight, noise.inverse(), first_onset, min_segment)
    split_onset = first_onset + split.onset if split.statistic > 0 else None
    split_significant = split_is_significant(split, n)
    cuts = [split_onset] if split_significant else []
    pieces = _pieces(sig.segments, cuts)
    # The corrections and levels are those of the disturbance less its steps and ramps: fitted
    # with them in, the AR gets roots near 1 (A(1) 0.5 on a ramped test loop, 1.2 without),
    # and whitening with it differences the record, so the controller's reaction to the noise
    # correlates with the whitened error (the direct method's closed-loop bias) and poses as
    # a channel change present throughout. The steps themselves are fitted beside every
    # candidate (process.py).
    onsets, steps = disturbance_steps(e0, weight > 0, noise.inverse(), first_onset, max(min_segment // 60, 1),
                                      max(first_onset, 2 * SETTLE), math.log(n))
    free = e0 - steps
    inputs = input_basis(sig, i, noise.inverse())
    ar, sigma, root = _corrections(free, pieces, inputs, root_grid(noise), cuts)
    parity = (np.arange(n) // block) % 2
    out = OutputResidual(sig=sig, i=i, name=sig.outputs[i], v=v, e=e, weight=weight, split=split,
                         split_onset=split_onset, split_significant=split_significant, pieces=pieces,
                         ar=ar, sigma=sigma, r=np.zeros(n), fold=[weight * (parity == 0), weight * (parity == 1)],
                         block=block, n=int(weight.sum()), noise_estimated=noise_estimated, disturbance_onsets=onsets,
                         free=free, inputs=inputs, root=root)
    out.r = out.whiten(np.nan_to_num(v))
    return out


def without_split(out: OutputResidual) -> OutputResidual:
    """The same residual under the hypothesis that the disturbance did not change: one AR
    correction per data segment, no split."""
    pieces = _pieces(out.sig.segments, [])
    ar, sigma, root = _corrections(out.free, pieces, out.inputs, out.offered_roots)
    flat = dataclasses.replace(out, split_significant=False, pieces=pieces, ar=ar, sigma=sigma, root=root,
                               nuisance=None)
    flat.r = flat.whiten(np.nan_to_num(out.v))
    return flat


def _corrections(free: np.ndarray, pieces: list[tuple[int, int]], inputs: np.ndarray, grid: tuple,
                 cuts=()) -> tuple[list[np.ndarray], list[float], list[float]]:
    """The AR correction A_s, innovation RMS and moving-average root c_s of each piece (the AR
    fitted beside ``inputs``, the innovation without them: what the whitened residual's variance
    is), one triple per disturbance regime (the pieces between the ``cuts``, the noise split's
    onsets): the data segments a historian's lost samples cut a regime into share its
    disturbance, and a correction fitted to each alone is noisier (tuning day-long records with
    the PV lost every 250 rows: 40 -> 49 of 60 changes named, 51 on the complete records) and
    needs MIN_AR_ROWS_PER_COEFFICIENT * AR_ORDER rows after SETTLE in every segment. The root,
    one of ``grid`` (``root_grid``), is chosen (``root_ar``) on the rows after the slowest root's
    start-up, so that every root is scored on the same rows (roots that need more than half the
    regime's shortest piece to forget their start are not tried); A_s is fitted on the rows
    after SETTLE."""
    regime = [int(np.searchsorted(np.sort(cuts), a, side="right")) for a, _ in pieces]
    ar, sigma, root = [None] * len(pieces), [0.0] * len(pieces), [0.0] * len(pieces)
    for r in sorted(set(regime)):
        mine = [pieces[k] for k, g in enumerate(regime) if g == r]
        shortest = min(b - a for a, b in mine)
        roots = [c for c in grid if _forgetting(c) <= shortest // 2]
        skip = max(SETTLE, _forgetting(roots[-1]))
        settled = _after_start(len(free), mine, SETTLE)
        c, poly = root_ar(free, mine, _after_start(len(free), mine, skip), inputs, roots,
                          fit_rows=settled if skip > SETTLE else None)
        w = filter_pieces(correction(poly, c), free, mine)[settled]
        for k, g in enumerate(regime):
            if g == r:
                ar[k], sigma[k], root[k] = poly, float(np.sqrt(np.mean(w**2))), c
    return ar, sigma, root


def root_grid(noise: TransferFunction) -> tuple:
    """CORRECTION_ROOTS for an output whose noise model (the file's or the estimated one) has a
    pole within 1 - WANDERING_POLE of the unit circle, a wandering disturbance (``root_ar``);
    (0,) otherwise: no root. Offered on every output, a root near 1 took up a process change
    present in the error (an unsplit regime after a dead-time change) as readily as it undid a
    wandering disturbance (docs/diagnose.md "A wandering disturbance")."""
    poles = np.abs(noise.poles())
    return CORRECTION_ROOTS if len(poles) and poles.max() >= WANDERING_POLE else (0.0,)


def root_ar(x: np.ndarray, pieces: list[tuple[int, int]], rows: np.ndarray, inputs: np.ndarray | None,
            roots: tuple, order: int = AR_ORDER, fit_rows: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """(c, A): the moving-average root c of ``roots`` and the AR(order) A that whiten x best,
    A(q) / (1 - c q^-1) x, by BIC on ``rows`` with one coefficient charged for c > 0; A refitted
    on ``fit_rows`` when given. Each root filters x (and ``inputs``, beside which A is fitted)
    from rest in each of ``pieces``, as ``whiten_piece`` does. A disturbance that wanders
    (nearly integrated, with white noise on top: (1 - c q^-1) / (1 - a q^-1), a near 1) has an
    inverse whose memory c^k no AR of this order holds; after its colour changes, its old
    inverse leaves the error nearly differenced, (1 - a q^-1) times the new disturbance, which
    only a root near a undoes. The colour left is carried into the inputs by the controller,
    where candidates take it for a process change (docs/diagnose.md "A wandering
    disturbance")."""
    best = None
    for c in roots:
        through = correction(np.ones(1), c)
        # c = 0 filters nothing: x is used as it is (the rows and their lags lie in the pieces)
        xc = filter_pieces(through, x, pieces) if c else x
        zc = filter_pieces(through, inputs, pieces) if c and inputs is not None else inputs
        poly = masked_ar(xc, rows, order, zc)
        bic = _bic(poly, c, xc, pieces, rows) if len(roots) > 1 else 0.0
        if best is None or bic < best[0]:
            best = (bic, c, xc, zc, poly)
    _, c, xc, zc, poly = best
    return c, poly if fit_rows is None else masked_ar(xc, fit_rows, order, zc)


def _bic(poly: np.ndarray, c: float, xc: np.ndarray, pieces: list[tuple[int, int]], rows: np.ndarray) -> float:
    """BIC of the whitened xc on ``rows``, the AR's coefficients being common to every root."""
    w = filter_pieces(TransferFunction(poly, [1.0], 0), xc, pieces)[rows]
    return len(w) * math.log(np.mean(w**2)) + (math.log(len(w)) if c else 0.0)


def filter_pieces(f: TransferFunction, x: np.ndarray, pieces: list[tuple[int, int]]) -> np.ndarray:
    """f x (each column of x) from rest in each piece, zero outside them."""
    columns = x.reshape(len(x), -1)
    out = np.zeros(columns.shape)
    for a, b in pieces:
        for j in range(columns.shape[1]):
            out[a:b, j] = f.filter(columns[a:b, j])
    return out.reshape(x.shape)


def _after_start(n: int, pieces: list[tuple[int, int]], skip: int) -> np.ndarray:
    """Rows of the pieces after their first ``skip``."""
    rows = np.zeros(n, bool)
    for a, b in pieces:
        rows[a + skip:b] = True
    return rows


def _forgetting(c: float) -> int:
    """Samples until 1 / (1 - c q^-1), started at rest, has forgotten its missing past to 1 %."""
    return math.ceil(math.log(0.01) / math.log(c)) if c else 0


def correction(ar: np.ndarray, c: float) -> TransferFunction:
    """A(q) / (1 - c q^-1)."""
    return TransferFunction(ar, [1.0, -c] if c else [1.0], 0)


def input_basis(sig: Signals, i: int, prefilter: TransferFunction | None = None) -> np.ndarray:
    """The inputs of output i's channels through INPUT_BASIS_FUNCTIONS Laguerre functions on its
    slowest pole, each delayed to BASIS_LEAD samples before the channel's delay
    (laguerre.delayed_before), per data segment, through ``prefilter`` (the noise model's
    inverse for a one-step error). An input reaches the output through its channel only after
    the dead time; at shorter lags
    it carries the controller's reaction to the disturbance (feedback), and a basis starting
    at lag 1 took that part of the disturbance from the AR: on the hidden-effect suite's
    dead-time change 12 -> 19 samples, a channel delayed 2 samples at 1.67x then fitted the
    feedback better than the true change fitted the data."""
    filters = laguerre_filters(laguerre_pole(sig, i), INPUT_BASIS_FUNCTIONS)
    columns = []
    for j, g in enumerate(sig.rows[i]):
        if g is None:
            continue
        columns.append(output_basis(sig, i, delayed_before(np.nan_to_num(sig.u[:, j]), g.delay)[:, None], filters))
    if not columns:
        return np.zeros((len(sig.time_s), 0))
    x = np.nan_to_num(np.column_stack(columns))
    if prefilter is None:
        return x
    return np.nan_to_num(filtered_columns(sig, [prefilter], x))


def disturbance_steps(e: np.ndarray, ok: np.ndarray, hinv: TransferFunction, first_onset: int, grid: int,
                      earliest: int, logn: float) -> tuple[list[int], np.ndarray]:
    """Onsets of the step + ramp disturbances in the one-step error e and their fitted sum with
    the level (H^-1-filtered). Greedy: each onset is the best single step + ramp (``trend_fit``) on what
    the earlier ones left, then all steps, slopes and the level are refitted jointly (a ramp that
    stops is two breakpoints); kept while one removes more than 3 log N variances of what is left
    (BIC: onset, step, slope)."""
    n = len(e)
    onsets, total = [], np.zeros(n)
    scan = TrendScan(ok, hinv, grid, earliest)
    s, r = scan.s, scan.r
    columns = [np.ones(n)]
    for _ in range(MAX_DISTURBANCE_STEPS):
        fit = scan.fit(e - total, first_onset)
        if not fit.drop > 3.0 * logn * np.var((e - total)[ok]):
            break
        k = fit.onset
        onsets.append(k)
        columns += [np.r_[np.zeros(k), s[: n - k]], np.r_[np.zeros(k), r[: n - k]]]
        x = np.column_stack(columns)
        coef = np.linalg.lstsq(x[ok], e[ok], rcond=None)[0]
        total = x @ coef
    return onsets, total


@dataclass
class Nuisance:
    """An output's level and its unmeasured step + ramp disturbances, as whitened columns.
    Fitting a candidate to data with these projected out is fitting it jointly with them
    (Frisch-Waugh-Lovell). The level is there because the record mean removed from y is not
    the mean of an output that stepped."""

    onsets: list[int]
    columns: np.ndarray = field(repr=False)      # n x (1 + 2 * len(onsets))
    weight: np.ndarray = field(repr=False)

    def __post_init__(self):
        # the weighted least-squares solve, formed once: every candidate response is projected
        z = self.columns * self.weight[:, None]
        self.solve = np.linalg.pinv(z.T @ self.columns) @ z.T

    def project(self, x: np.ndarray) -> np.ndarray:
        """x less its weighted least-squares fit on the columns."""
        return x - self.columns @ (self.solve @ x)

    def scan(self, r: np.ndarray, odd: np.ndarray, begin: int, min_segment: int,
             step: int, onset_penalty: float) -> _core.ProjectedOnsetScan:
        """Cross-validated onset scans (fold ``odd``) of candidates fitted beside the columns to
        the projected residual ``r``; a candidate is passed unprojected. An onset after
        ``begin`` must beat ``begin``'s statistic by ``onset_penalty``."""
        return _core.ProjectedOnsetScan(r, self.weight, odd, self.columns, self.solve, begin, min_segment, step,
                                        onset_penalty)


def disturbance_onsets(out: OutputResidual, e: np.ndarray, first_onset: int, grid: int) -> list[int]:
    """Breakpoints of the step + ramp disturbances in a one-step error ``e`` of the output
    (``disturbance_steps`` on an onset grid of ``grid`` samples)."""
    return disturbance_steps(np.nan_to_num(e), out.weight > 0, out.noise.inverse(), first_onset, grid,
                             max(first_onset, 2 * SETTLE), math.log(len(e)))[0]


def disturbance_drives(out: OutputResidual, onsets: list[int]) -> list[np.ndarray]:
    """The level and, from each onset on, a step and a ramp (per hour), as output errors. An
    output with an integrating channel also gets a ramp per segment and a level per later
    segment: its channels are filtered from rest at each segment's start, and an input away
    from the operating point the record's mean guesses makes the integrator's output error
    ramp (any offset of a level loop's OP from its balance), which is no model error."""
    n, hour = len(out.e), out.sig.samples_per_hour
    t = np.arange(n, dtype=float)
    drives = [np.ones(n)] + [np.where(t >= k, d, 0.0) for k in onsets for d in (np.ones(n), (t - k) / hour)]
    if row_integrates(out.row):
        for k, (a, b) in enumerate(out.sig.segments):
            inside = (t >= a) & (t < b)
            drives += [np.where(inside, t - a, 0.0) / hour] + ([inside.astype(float)] if k else [])
    return drives


def disturbance_nuisance(out: OutputResidual, onsets: list[int]) -> Nuisance:
    """The output's level and steps + ramps from ``onsets`` on, whitened as its residual."""
    columns = [out.whiten(d) for d in disturbance_drives(out, onsets)]
    return Nuisance(list(onsets), np.column_stack(columns), out.weight)


def _pieces(segments, cuts):
    out = []
    for a, b in segments:
        inner = sorted(c for c in cuts if a + 2 * SETTLE < c < b - 2 * SETTLE)
        edges = [a, *inner, b]
        out += list(zip(edges[:-1], edges[1:]))
    return out


def has_noise_model(h: TransferFunction) -> bool:
    """False for H = 1, what the model format gives an output without a noise model."""
    return not (h.delay == 0 and np.array_equal(h.num, [1.0]) and np.array_equal(h.den, [1.0]))


def estimated_noise_model(sig: Signals, i: int, rows: np.ndarray, beside_inputs: bool = True) -> TransferFunction:
    """H = 1 / A(q), A the least-squares AR(NOISE_ORDER) of the output error y_i - G_i u on
    ``rows`` less its best step + ramp and its mean (roots reflected inside the unit circle,
    so H^-1 = A and H are stable), fitted beside the inputs' basis (``input_basis``) unless
    ``beside_inputs`` is False. A drift is a candidate of its own: an AR fitted with it
    gets a root near 1 whose inverse differences the drift, and the controller's
    compensation of it, away before any candidate can explain it, and the compensation's
    leftovers then pose as a channel change."""
    v = np.nan_to_num(output_error(sig, i, sig.rows[i], sig.u))
    usable = rows & used_rows(sig, i, TransferFunction(), NOISE_ORDER)
    free = v - trend_fit(v, usable, TransferFunction(), 0, TREND_GRID, 2 * SETTLE).trend
    free -= free[usable].mean()
    basis = input_basis(sig, i) if beside_inputs else None
    return TransferFunction([1.0], stable(first_part_ar(free, usable, basis)), 0)


def estimated_noise_models(sig: Signals, rows: np.ndarray) -> tuple[list[TransferFunction], list[str], dict]:
    """The outputs' noise models with ``estimated_noise_model`` (on ``rows``) for every output
    the model gives none: (noise models, the outputs estimated, output -> why none could be)."""
    noise, estimated, failed = list(sig.noise), [], {}
    for i, name in enumerate(sig.outputs):
        if has_noise_model(noise[i]):
            continue
        try:
            noise[i] = estimated_noise_model(sig, i, rows)
            estimated.append(name)
        except InsufficientData as exc:
            failed[name] = str(exc)
    return noise, estimated, failed


def estimated_noise_note(name: str, training: bool = False) -> str:
    """What ``diagnose`` and ``compare`` say of an output whose disturbance model they estimated."""
    return (f"{name}: the model has no noise model; its disturbance model was estimated from the data "
            f"(AR({NOISE_ORDER}) of the output error" + (", training rows)" if training else ")"))


def first_part_ar(free: np.ndarray, usable: np.ndarray, basis: np.ndarray | None) -> np.ndarray:
    """The disturbance AR (``disturbance_ar``) of the record, or of its first part when the
    record's AR is decisively wrong there. The first of REFERENCE_PARTS consecutive parts of the
    usable rows, about its own level, is the reference period (what a model file's noise model
    describes: the plant before any change); its AR replaces the record's when the record's
    leaves more one-step error A(q) e on it by REFERENCE_EVIDENCE chi-square units (n log of the
    variance ratio; the bound of the studies' top evidence bin). Fitted on the whole record, the
    AR takes up a process change from its onset on (one set of basis coefficients cannot follow
    a channel that changes mid-record) and whitens away most of the evidence for it: on the
    tuning family mpc_3x3 (seeds 0-39, no noise model) the true change kept a median 28 % of the
    one-step evidence the true disturbance model gives it; six runs named the wrong effect or
    none, all six right with the true disturbance model (docs/diagnose.md "The disturbance model
    of the record's first part"). A record under REFERENCE_PART_ROWS per part keeps the record's
    AR: a short hand-written loop's noise-change control (pi_siso_brief seed 15) got a false
    dead time at 0.95 from a first part of 1069 rows."""
    whole = disturbance_ar(free, usable, basis)
    rows = np.flatnonzero(usable)
    if len(rows) < REFERENCE_PARTS * REFERENCE_PART_ROWS:
        return whole
    mask = np.zeros(len(free), bool)
    mask[np.array_split(rows, REFERENCE_PARTS)[0]] = True
    # about the part's own level: the trend fitted to the whole record leaves the part an
    # offset, which an AR fitted to it reads as low-frequency noise
    part = free - free[mask].mean()
    poly = disturbance_ar(part, mask, basis)
    own, record = (float(np.mean(TransferFunction(a, [1.0], 0).filter(part)[mask] ** 2)) for a in (poly, whole))
    return poly if own > 0.0 and record > own * math.exp(REFERENCE_EVIDENCE / mask.sum()) else whole


def disturbance_ar(e: np.ndarray, mask: np.ndarray, inputs: np.ndarray | None) -> np.ndarray:
    """A(q) of an estimated noise model: the AR(NOISE_ORDER) of ``e`` on the rows in mask,
    beside the columns ``inputs`` (masked_ar), unless that AR alone leaves more than
    AMPLIFYING times the squared error of no AR at all; then the plain AR. Under a linear
    controller with no excitation the inputs' past is nearly a filter of the error's past,
    the split between the AR and the inputs' coefficients is then arbitrary, and the AR part
    alone can amplify (tuning family mpc_level, seed 8, an exact model: 4.4 times, and the
    error whitened by it confirmed a dead time 3 samples instead of 1 at 0.99). Not at any
    excess over no AR: the plain AR takes up part of a wrong channel's error (a hand-written
    model of twice the gain then read as 0.72x). The per-regime corrections (AR_ORDER, fitted
    on an error this model has whitened) keep the AR beside the inputs: on tuning draws a
    correction that alone left 2.9 times named a valve saturation that the plain AR's did
    not (mpc_2x2_spiky, seed 3)."""
    poly = masked_ar(e, mask, NOISE_ORDER, inputs)
    if inputs is None:
        return poly
    _, target, lagged = _lagged(e, mask, NOISE_ORDER)
    if np.sum((target + lagged @ poly[1:]) ** 2) <= AMPLIFYING * np.sum(target**2):
        return poly
    return masked_ar(e, mask, NOISE_ORDER)


def _lagged(e: np.ndarray, mask: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows in mask from ``order`` on, e there, and its lags 1..order there (columns)."""
    rows = np.flatnonzero(mask)
    rows = rows[rows >= order]
    return rows, e[rows], e[rows[:, None] - np.arange(1, order + 1)]


def masked_ar(e: np.ndarray, mask: np.ndarray, order: int = AR_ORDER, inputs: np.ndarray | None = None) -> np.ndarray:
    """Least-squares AR(order) on the rows in mask (lags may reach outside it), beside the
    columns ``inputs`` when given (ARX; their coefficients are dropped)."""
    rows, target, lagged = _lagged(e, mask, order)
    if len(target) < MIN_AR_ROWS_PER_COEFFICIENT * order:
        raise InsufficientData(f"{len(target)} rows for an AR({order}) fit")
    if inputs is not None:
        # an input that never moves on these rows leaves a zero column: minimum-norm solution
        a = np.linalg.lstsq(np.column_stack([lagged, inputs[rows]]), target, rcond=None)[0]
        return np.r_[1.0, -a[:order]]
    try:
        a = np.linalg.solve(lagged.T @ lagged, lagged.T @ target)
    except np.linalg.LinAlgError:
        raise InsufficientData(f"the error has no variation to fit an AR({order}) to") from None
    return np.r_[1.0, -a]


def stable(poly: np.ndarray) -> np.ndarray:
    """Reflect roots outside the unit circle inside (same spectrum shape): H/A must be stable."""
    roots = np.roots(poly)
    if np.all(np.abs(roots) < 1.0):
        return poly
    mag = np.abs(roots)
    roots = np.where(mag >= 1.0, np.minimum(1.0 / np.maximum(mag, 1e-12), 0.999) * roots / np.maximum(mag, 1e-12), roots)
    return np.real(np.poly(roots))
