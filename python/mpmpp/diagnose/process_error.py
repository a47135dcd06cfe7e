"""The process part of the output error: what a right fix makes fall.

The one-step error H^-1 (y - G u) is dominated by the disturbance, so a right fix barely moves
it (a doubled gain shows a few per cent). What the fix removes is the part of y - G u the
inputs explain, (G_true - G) u, the simulation (multi-step) error of the output's process part.
It is measured without knowing G_true: a linear filter of the inputs, expanded on an orthonormal
Laguerre basis (LAGUERRE_FUNCTIONS per input, pole from the model's slowest channel of the output;
every basis function has a one-sample delay, no lag 0: in closed loop u(t) may already react to
y(t)), is fitted to y - G u on the even 1 h blocks after the onset, in the whitened domain
(regress H^-1 (y - G u) on H^-1 of the basis responses, the prediction-error fit that keeps the
estimate consistent under coloured noise; a level term takes up the operating-point offset a
gain change leaves between the record mean and either model), and its output, unwhitened, is
the process part. Reported: its RMS on the odd blocks after the onset, which the fit never saw,
with the nominal model and with the model ``update`` writes. With a right model it falls to the
estimation floor, about sigma_v sqrt(n_u K / N_even): a Laguerre basis needs far fewer
parameters than a FIR long enough for slow channels, so the floor sits well below a typical
model error.
"""
from __future__ import annotations

import numpy as np

from .._core import TransferFunction
from ..signals import Signals, bridged_reach, filtered_columns, per_segment
from .errors import one_step_errors
from .laguerre import laguerre_filters, laguerre_pole, output_basis
from .result import ModelChange

MIN_FIT_ROWS = 50


def explanatory_columns(sig: Signals, changes: list[ModelChange]) -> tuple[list[str], np.ndarray]:
    """The model's inputs and any data column a change makes a new model input (NaN kept)."""
    names = list(sig.inputs)
    cols = [sig.u[:, j] for j in range(len(sig.inputs))]
    for c in changes:
        if c.new_input and c.input not in names:
            names.append(c.input)
            cols.append(sig.z[:, sig.extras.index(c.input)])
    return names, np.column_stack(cols)


class ProcessBasis:
    """The regressors of the process-part fit: the explanatory columns through the basis
    filters, a level term, and their whitening per noise model. They do not depend on the
    model being judged, so the fits before and after a change share them."""

    def __init__(self, sig: Signals, i: int, columns: np.ndarray, filters: list[TransferFunction]):
        self.sig = sig
        self.columns = columns
        self.x = output_basis(sig, i, columns, filters)
        # The level term: the step from each segment's start (an operating-point offset).
        self.regressors = np.column_stack([self.x, per_segment(sig, np.ones_like, np.ones(len(self.x)))])
        self._whitened: dict = {}

    def whitened(self, noise: TransferFunction) -> np.ndarray:
        key = (tuple(noise.num), tuple(noise.den), noise.delay)
        if key not in self._whitened:
            self._whitened[key] = filtered_columns(self.sig, [noise.inverse()], self.regressors)
        return self._whitened[key]


def process_part(sig: Signals, i: int, changes: list[ModelChange], onset: int, block: int,
                 basis: ProcessBasis, end: int | None = None) -> np.ndarray:
    """The input-explained part of y_i - G_i u (G the model after ``changes``) on every usable
    row from ``onset`` to ``end`` (the record's end when None), NaN elsewhere (all NaN when the
    blocks there are too short); fitted on the even blocks there only."""
    noise = sig.noise[i]
    for c in changes:
        if c.output == sig.outputs[i] and c.noise is not None:
            noise = c.noise
    e = one_step_errors(sig, i, changes)
    x, columns = basis.x, basis.columns
    t = np.arange(len(e))
    end = len(e) if end is None else end
    usable = (t >= onset) & (t < end) & np.isfinite(e) & np.isfinite(columns).all(axis=1) & np.isfinite(x).all(axis=1)
    usable &= ~bridged_reach(sig, i, noise.inverse(), 0)
    odd = (t // block) % 2 == 1
    fit = usable & ~odd
    series = np.full(len(e), np.nan)
    if fit.sum() < max(MIN_FIT_ROWS, 2 * basis.regressors.shape[1]) or not (usable & odd).any():
        return series
    b = np.linalg.lstsq(basis.whitened(noise)[fit], e[fit], rcond=None)[0][:-1]
    series[usable] = x[usable] @ b
    return series


def held_out_rms(series: np.ndarray, block: int) -> float:
    """RMS of a process part on the odd blocks (the rows its fit did not see)."""
    test = np.isfinite(series) & ((np.arange(len(series)) // block) % 2 == 1)
    return float(np.sqrt(np.mean(series[test] ** 2))) if test.any() else float("nan")


def process_error(sig: Signals, i: int, changes: list[ModelChange], onset: int, block: int,
                  columns: np.ndarray, filters: list[TransferFunction]) -> float:
    """RMS on the odd blocks after ``onset`` of the input-explained part of y_i - G_i u, G the
    model after ``changes``; fitted on the even blocks after ``onset``."""
    return held_out_rms(process_part(sig, i, changes, onset, block, ProcessBasis(sig, i, columns, filters)), block)


def process_parts(sig: Signals, i: int, changes: list[ModelChange], onset: int,
                  block: int, end: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(before, after): the process part from ``onset`` to ``end`` with the nominal model's
    channels and with those of ``changes``, both with the same explanatory columns and basis and
    both whitened with the noise model after ``changes``. G u is all the process part depends on;
    the noise model only weights its fit, and a fit weighted by a noise model the data reject
    reads part of the disturbance as input-explained (in closed loop the inputs follow the
    disturbance): examples/mimo_noise_change's noise change showed moisture's process part
    falling 0.0169 -> 0.0073 with G unchanged."""
    _, columns = explanatory_columns(sig, changes)
    basis = ProcessBasis(sig, i, columns, laguerre_filters(laguerre_pole(sig, i)))
    noise_only = [ModelChange(c.output, noise=c.noise) for c in changes if c.noise is not None]
    return (process_part(sig, i, noise_only, onset, block, basis, end),
            process_part(sig, i, changes, onset, block, basis, end))


def process_errors(sig: Signals, i: int, changes: list[ModelChange], onset: int,
                   block: int) -> tuple[float, float]:
    """(before, after): the process-part error with the nominal model and with ``changes``
    (NaN when the held-out blocks after the onset are too short for the fit)."""
    before, after = process_parts(sig, i, changes, onset, block)
    return held_out_rms(before, block), held_out_rms(after, block)
