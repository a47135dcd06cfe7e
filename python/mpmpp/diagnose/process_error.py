"""The process part of the output error: what a right fix makes fall.

The one-step error H^-1 (y - G u) is dominated by the disturbance, so a right fix barely moves
it (a doubled gain shows a few per cent). What the fix removes is the part of y - G u the
inputs explain, (G_true - G) u, the simulation (multi-step) error of the output's process part.
It is measured without knowing G_true: a FIR of the inputs (lags 1..L, no lag 0: in closed loop
u(t) may already react to y(t)) is fitted to y - G u on the even 1 h blocks after the onset, in
the whitened domain (regress H^-1 (y - G u) on H^-1 u(t - k), the prediction-error fit that
keeps the estimate consistent under coloured noise; a level term takes up the operating-point
offset a gain change leaves between the record mean and either model), and its output,
unwhitened, is the process part. Reported: its RMS on the odd blocks after the onset, which the fit never saw, with the
nominal model and with the model ``update`` writes. With a right model it falls to the
estimation floor, about sigma_v sqrt(L n_u / N_even).
"""
from __future__ import annotations

import math

import numpy as np

from ..signals import Signals, per_segment
from .errors import one_step_errors
from .result import ModelChange

# At most 60 lags: the fit costs N (n_u L)^2, and on a week of 3x3 data at 5 s 120 lags
# would cost seconds per finding; a slower tail is left out of before and after alike.
MIN_LAGS, MAX_LAGS = 10, 60
MIN_FIT_ROWS = 50


def fir_lags(sig: Signals, i: int) -> int:
    """FIR length for output i: the longest delay of its channels plus 15 samples (a delay
    change of the searched size) plus 3 of its slowest time constant, within MIN_LAGS..MAX_LAGS."""
    longest = 0.0
    for g in sig.rows[i]:
        if g is None:
            continue
        poles = np.abs(np.asarray(g.poles()))
        tau = max([-1.0 / math.log(p) for p in poles if 0.0 < p < 1.0], default=0.0)
        longest = max(longest, g.delay + 3.0 * tau)
    return int(min(max(longest + 15, MIN_LAGS), MAX_LAGS))


def explanatory_columns(sig: Signals, changes: list[ModelChange]) -> tuple[list[str], np.ndarray]:
    """The model's inputs and any data column a change makes a new model input (NaN kept)."""
    names = list(sig.inputs)
    cols = [sig.u[:, j] for j in range(len(sig.inputs))]
    for c in changes:
        if c.new_input and c.input not in names:
            names.append(c.input)
            cols.append(sig.z[:, sig.extras.index(c.input)])
    return names, np.column_stack(cols)


def lagged(x: np.ndarray, rows: np.ndarray, segment_start: np.ndarray, lags: int) -> np.ndarray:
    """[x(t-1) .. x(t-lags)] for each column of x and each row t in ``rows`` (column-major
    blocks of ``lags``), zero where t - k falls before the row's data segment."""
    idx = rows[:, None] - np.arange(1, lags + 1)[None, :]
    inside = idx >= segment_start[rows][:, None]
    idx = np.where(inside, idx, 0)
    return np.concatenate([np.where(inside, x[idx, j], 0.0) for j in range(x.shape[1])], axis=1)


def _chunks(rows: np.ndarray, size: int = 20000):
    """Row chunks, so the lag matrices stay small on records of days."""
    for a in range(0, len(rows), size):
        yield rows[a:a + size]


def process_part(sig: Signals, i: int, changes: list[ModelChange], onset: int, block: int,
                 columns: np.ndarray, lags: int) -> np.ndarray:
    """The input-explained part of y_i - G_i u (G the model after ``changes``) on every usable
    row after ``onset``, NaN elsewhere (all NaN when the blocks after the onset are too short);
    the FIR is fitted on the even blocks after ``onset`` only."""
    noise = sig.noise[i]
    for c in changes:
        if c.output == sig.outputs[i] and c.noise is not None:
            noise = c.noise
    e = one_step_errors(sig, i, changes)
    raw = np.nan_to_num(columns)
    whitened = per_segment(sig, lambda xs: np.column_stack(
        [noise.inverse().filter(xs[:, k]) for k in range(xs.shape[1])]), raw)
    segment_start = np.zeros(len(e), dtype=np.int64)
    for a, b in sig.segments:
        segment_start[a:b] = a
    t = np.arange(len(e))
    usable = (t >= onset) & np.isfinite(e) & np.isfinite(columns).all(axis=1)
    odd = (t // block) % 2 == 1
    fit = np.flatnonzero(usable & ~odd)
    m = columns.shape[1] * lags
    series = np.full(len(e), np.nan)
    if len(fit) < max(MIN_FIT_ROWS, 2 * m) or not (usable & odd).any():
        return series
    # A level term (the whitened step from each segment's start) takes up an operating-point
    # offset: the record mean is the operating point of neither model when a gain changed.
    level = per_segment(sig, lambda ones: noise.inverse().filter(ones), np.ones(len(e)))
    gram, moment = np.zeros((m + 1, m + 1)), np.zeros(m + 1)
    for rows in _chunks(fit):
        x = np.column_stack([lagged(whitened, rows, segment_start, lags), level[rows]])
        gram += x.T @ x
        moment += x.T @ e[rows]
    b = np.linalg.lstsq(gram, moment, rcond=None)[0][:m]
    for rows in _chunks(np.flatnonzero(usable)):
        series[rows] = lagged(raw, rows, segment_start, lags) @ b
    return series


def held_out_rms(series: np.ndarray, block: int) -> float:
    """RMS of a process part on the odd blocks (the rows its FIR was not fitted on)."""
    test = np.isfinite(series) & ((np.arange(len(series)) // block) % 2 == 1)
    return float(np.sqrt(np.mean(series[test] ** 2))) if test.any() else float("nan")


def process_error(sig: Signals, i: int, changes: list[ModelChange], onset: int, block: int,
                  columns: np.ndarray, lags: int) -> float:
    """RMS on the odd blocks after ``onset`` of the input-explained part of y_i - G_i u, G the
    model after ``changes``; the FIR is fitted on the even blocks after ``onset``."""
    return held_out_rms(process_part(sig, i, changes, onset, block, columns, lags), block)


def process_parts(sig: Signals, i: int, changes: list[ModelChange], onset: int,
                  block: int) -> tuple[np.ndarray, np.ndarray]:
    """(before, after): the process part with the nominal model and with ``changes``, both with
    the same explanatory columns and FIR length."""
    _, columns = explanatory_columns(sig, changes)
    lags = fir_lags(sig, i)
    return (process_part(sig, i, [], onset, block, columns, lags),
            process_part(sig, i, changes, onset, block, columns, lags))


def process_errors(sig: Signals, i: int, changes: list[ModelChange], onset: int,
                   block: int) -> tuple[float, float]:
    """(before, after): the process-part error with the nominal model and with ``changes``
    (NaN when the held-out blocks after the onset are too short for the fit)."""
    before, after = process_parts(sig, i, changes, onset, block)
    return held_out_rms(before, block), held_out_rms(after, block)
