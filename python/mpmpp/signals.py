"""Turn a model + operating-data pair into the deviation signals the numerics work on.

The data are absolute engineering units (docs/formats.md), the model's transfer functions act on
deviations from an operating point. We take the operating point as the sample mean of each
column over a reference span (the whole record unless the caller gives one) and subtract it.
Rows with a missing value split the record into NaN-free segments; every filter restarts at the
start of a segment, and segments shorter than ``min_segment`` are skipped and reported. The one
exception is a few lost output samples (``bridge_lost_outputs``): those are interpolated, and
the analyses leave out the errors that read them (``Signals.bridged``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .held_values import require_computable, require_moving_outputs, require_recorded_columns
from .timeaxis import seconds_of


@dataclass
class Signals:
    """Deviation signals of one model/data pair (all arrays are N long, row t = data row t)."""

    time_s: np.ndarray
    inputs: list[str]
    outputs: list[str]
    extras: list[str]                 # candidate columns: neither model input/output nor a setpoint
    u: np.ndarray                     # N x nu input deviations
    y: np.ndarray                     # N x ny output deviations
    z: np.ndarray                     # N x nz extra-column deviations
    operating_point: dict[str, float]
    segments: list[tuple[int, int]]   # NaN-free [start, stop) row ranges used
    skipped_rows: int = 0
    sample_time_s: float = 1.0
    bridged: np.ndarray | None = None  # N x ny: output samples lost and interpolated (bridge_lost_outputs)
    rows: list = field(default_factory=list)    # model rows: list per output of [TF or None]
    noise: list = field(default_factory=list)   # noise model per output

    def seconds_to_index(self, seconds: float) -> int:
        return int(np.searchsorted(self.time_s, seconds, side="left"))

    @property
    def samples_per_hour(self) -> float:
        """Samples in an hour (the unit of a drift's ramp)."""
        return 3600.0 / self.sample_time_s


def model_rows(model) -> tuple[list, list]:
    """Per output, the list of its channels (TransferFunction or None) and its noise model."""
    rows = [[model.process(o, i) for i in model.inputs] for o in model.outputs]
    noise = [model.noise(o) for o in model.outputs]
    return rows, noise


# Above 1 by more than rounding a pole is unstable; at 1 the channel integrates (supported).
UNIT_CIRCLE_TOLERANCE = 1e-9


def require_simulable_channels(model, rows: int) -> None:
    """ValueError naming the first process channel an output-error analysis cannot run on
    these data: a pole outside the unit circle (simulated from the inputs, the output diverges),
    a gain beyond floating point (a step response of magnitude LARGEST_VALUE or more: the fits
    overflow; a model file's numbers are bounded on reading, a Model built in Python is not) or a
    dead time of the record's length or more (it never reaches the data; a dead time written in
    seconds where the file counts samples looks like this)."""
    from ._core import LARGEST_VALUE   # here: `mpmpp check -h` loads this module, not the engine

    for o in model.outputs:
        for i in model.inputs:
            g = model.process(o, i)
            if g is None:
                continue
            poles = np.abs(g.poles())
            if len(poles) and poles.max() > 1.0 + UNIT_CIRCLE_TOLERANCE:
                raise ValueError(f"model: process.{o}.{i}: unstable, a pole has |p| = {poles.max():.4g} > 1 (compare "
                                 "and diagnose simulate the model's output from its inputs; a model for them is "
                                 "stable or integrating)")
            if g.delay >= rows:
                raise ValueError(f"model: process.{o}.{i}.delay: {g.delay} samples ({g.delay * model.sample_time_s:g} s) "
                                 f"is as long as the record or longer ({rows} rows); the model file counts the delay "
                                 "in samples")
            step = g.step(2 * len(g.den) + g.delay + len(g.num))
            if not (np.all(np.isfinite(step)) and np.abs(step).max() < LARGEST_VALUE):
                raise ValueError(f"model: process.{o}.{i}: its step response reaches magnitude {LARGEST_VALUE:g} "
                                 "or more, which floating point cannot compute with "
                                 f"(num {[float(x) for x in g.num]}, den {[float(x) for x in g.den]}): check the channel's units")


def _numbers(column) -> np.ndarray | None:
    """A data frame's column as floats, or None for a text column (tag names, units, states),
    which is left out of the candidate columns as the file reader leaves it out."""
    try:
        return column.to_numpy(dtype=float)
    except (TypeError, ValueError):
        return None


def extract(model, data, reference=None, min_segment: int = 200) -> Signals:
    """Deviation signals of ``data`` (DataFrame with ``time`` in seconds) for ``model``.

    ``reference`` is a boolean row mask for the operating-point means (default: all rows).
    """
    inputs, outputs = list(model.inputs), list(model.outputs)
    for col in ["time", *inputs, *outputs]:
        if col not in data.columns:
            raise ValueError(f"data: missing column '{col}' required by the model")
    setpoints = {f"{o}_sp" for o in outputs}
    numbers = {c: _numbers(data[c]) for c in data.columns if c not in {"time", *inputs, *outputs, *setpoints}}
    extras = [c for c, x in numbers.items() if x is not None]
    time_s = seconds_of(data)
    raw_u = data[inputs].to_numpy(dtype=float)
    raw_y = data[outputs].to_numpy(dtype=float)
    raw_z = np.column_stack([numbers[c] for c in extras]) if extras else np.zeros((len(data), 0))
    require_recorded_columns(inputs, raw_u, outputs, raw_y)
    require_computable([*inputs, *outputs, *extras], np.column_stack([raw_u, raw_y, raw_z]), time_s)
    require_moving_outputs(outputs, raw_y)
    require_simulable_channels(model, len(data))
    ref = np.ones(len(data), bool) if reference is None else np.asarray(reference, bool)
    nu, ny = len(inputs), len(outputs)
    # rows a data frame leaves out (a historian gap: a step of two samples or more) end a
    # segment as a missing row would; load_data puts a file on the grid with missing rows
    gaps = np.flatnonzero(np.diff(time_s) > 1.5 * float(model.sample_time_s)) + 1
    raw_y, bridged = bridge_lost_outputs(raw_y, raw_u, gaps)
    valid = np.all(np.isfinite(np.column_stack([raw_u, raw_y])), axis=1)
    try:
        segments, skipped = complete_segments(valid, min_segment, gaps)
    except ValueError as exc:
        raise ValueError(f"{exc} ({missing_counts([*inputs, *outputs], np.column_stack([raw_u, raw_y]))})") from None
    raw_u = through_actuators(model, raw_u, segments)
    both = np.column_stack([raw_u, raw_y, raw_z])
    means = np.nanmean(both[ref], axis=0) if ref.any() else np.nanmean(both, axis=0)
    dev = both - means
    # Extra columns with NaNs do not cut the model signals; they are handled where used.
    rows, noise = model_rows(model)
    return Signals(
        time_s=time_s, inputs=inputs, outputs=outputs, extras=extras,
        u=dev[:, :nu], y=dev[:, nu:nu + ny], z=dev[:, nu + ny:],
        operating_point=dict(zip([*inputs, *outputs, *extras], map(float, means))),
        segments=segments, skipped_rows=skipped, sample_time_s=float(model.sample_time_s),
        rows=rows, noise=noise, bridged=bridged,
    )


# Lost output samples interpolated instead of splitting the record (bridge_lost_outputs).
MAX_BRIDGED_RUN = 2        # consecutive lost samples of one output
MAX_BRIDGED_SHARE = 0.01   # of an output's rows: beyond it, that output's lost samples split the record


def bridge_lost_outputs(raw_y: np.ndarray, raw_u: np.ndarray, starts=()) -> tuple[np.ndarray, np.ndarray]:
    """(``raw_y`` with its short runs of lost samples linearly interpolated, the N x ny mask of
    the samples filled). A run is filled when it holds at most MAX_BRIDGED_RUN rows, the samples
    either side of it are present, every input (``raw_u``, N x nu) is present from the sample
    before it to the one after, and no segment starts (``starts``: rows after a time gap) inside that span; an output
    with more such rows than MAX_BRIDGED_SHARE of the record keeps all of them lost.

    Why: a historian that drops a PV sample now and then (a 2 h export with four lost samples)
    otherwise cuts the record into pieces, each filtered from rest and the short ones skipped;
    on a 2 h PI loop with four lost PV samples half the record went, and diagnose named the
    model's gain error a stick-slip valve at confidence 0.97. The G u part of the output error
    reads no output, so only the noise filter sees the interpolated value: compare and diagnose
    leave out the errors within its reach (bridged_reach); identify keeps them in its criterion
    (model_identification.model_from_data)."""
    y = np.array(raw_y, dtype=float)
    inputs_present = np.isfinite(np.asarray(raw_u, dtype=float)).all(axis=1)
    filled = np.zeros(y.shape, bool)
    n = len(y)
    split = np.zeros(n + 1, bool)
    split[np.asarray(starts, dtype=int)] = True
    for k in range(y.shape[1]):
        runs = [(a, b) for a, b in complete_runs(~np.isfinite(y[:, k]))
                if b - a <= MAX_BRIDGED_RUN and a >= 1 and b < n and np.isfinite(y[a - 1, k]) and np.isfinite(y[b, k])
                and inputs_present[a - 1:b + 1].all() and not split[a:b + 1].any()]
        if not runs or sum(b - a for a, b in runs) > MAX_BRIDGED_SHARE * n:
            continue
        for a, b in runs:
            y[a:b, k] = np.interp(np.arange(a, b), [a - 1, b], [y[a - 1, k], y[b, k]])
            filled[a:b, k] = True
    return y, filled


def through_actuators(model, raw_u: np.ndarray, segments=None, inputs=None) -> np.ndarray:
    """The inputs the channels see: an input with an actuator in the model (its valve model,
    docs/stiction.md "Model file") is replaced by the simulated valve position, per segment
    (the valve starts at rest at each segment's first row); rows outside the segments are NaN.
    ``raw_u``'s columns are ``inputs`` (default: the model's); without ``segments``, each
    column's own runs of finite values."""
    actuators = model.actuators_dict()
    if not actuators:
        return raw_u
    from .stiction.valve import valve_position

    out = raw_u.copy()
    for j, name in enumerate(model.inputs if inputs is None else inputs):
        if name in actuators:
            runs = segments if segments is not None else complete_segments(np.isfinite(raw_u[:, j]), 1)[0]
            out[:, j] = np.nan
            for a, b in runs:
                out[a:b, j] = valve_position(actuators[name], raw_u[a:b, j])
    return out


def bridged_reach(sig: Signals, i: int, inverse_noise, lags: int) -> np.ndarray:
    """Rows whose error reads an interpolated sample of output i (bridge_lost_outputs):
    through ``inverse_noise`` (H^-1, its impulse response to 1 % of its peak) and then an AR of
    ``lags`` lags. The interpolation is not data, so these rows stay out of every fit and score."""
    n = len(sig.time_s)
    reach = np.zeros(n, bool)
    if sig.bridged is None or not sig.bridged[:, i].any():
        return reach
    h = np.abs(inverse_noise.impulse(4096))
    span = int(np.flatnonzero(h >= 0.01 * h.max())[-1]) + 1 + lags
    for t in np.flatnonzero(sig.bridged[:, i]):
        reach[t:t + span] = True
    return reach


def complete_runs(valid: np.ndarray, starts=()) -> list[tuple[int, int]]:
    """The stretches [a, b) of rows where ``valid`` holds, each also cut before every row of
    ``starts`` (rows that follow a time gap)."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], np.asarray(valid).astype(np.int8), [0]])))
    cuts = np.asarray(starts, dtype=int)
    runs = []
    for a, b in zip(edges[::2], edges[1::2]):
        bounds = [int(a), *(int(c) for c in cuts[(cuts > a) & (cuts < b)]), int(b)]
        runs += list(zip(bounds[:-1], bounds[1:]))
    return runs


def longest(runs) -> tuple[int, int]:
    """The longest of the row ranges ``runs`` [(a, b), ...] ((0, 0) when there is none)."""
    return max(runs, key=lambda r: r[1] - r[0], default=(0, 0))


def longest_run(valid: np.ndarray, starts=()) -> tuple[int, int]:
    """The longest of ``complete_runs`` ((0, 0) when there is none)."""
    return longest(complete_runs(valid, starts))


def missing_counts(names, columns: np.ndarray) -> str:
    """"missing values: y 1152, u 3" (or "none") for a message on a record without a complete
    stretch long enough: scattered missing values, not a short record, are then the cause."""
    counts = np.sum(~np.isfinite(np.asarray(columns, dtype=float)), axis=0)
    return "missing values: " + (", ".join(f"{name} {k}" for name, k in zip(names, counts) if k) or "none")


def complete_segments(valid: np.ndarray, min_segment: int, starts=()) -> tuple[list[tuple[int, int]], int]:
    """(the ``complete_runs`` of at least ``min_segment`` rows, the number of rows outside them);
    ValueError when there is none."""
    kept = [r for r in complete_runs(valid, starts) if r[1] - r[0] >= min_segment]
    if not kept:
        raise ValueError(f"data: no stretch of at least {min_segment} rows without missing values or time gaps")
    return kept, int(len(valid) - sum(b - a for a, b in kept))


def per_segment(signals: Signals, fn, *arrays) -> np.ndarray:
    """Apply ``fn(*segment_arrays)`` on each NaN-free segment; NaN outside the segments."""
    n = len(signals.time_s)
    out = None
    for a, b in signals.segments:
        res = np.asarray(fn(*(x[a:b] for x in arrays)))
        if out is None:
            out = np.full((n,) + res.shape[1:], np.nan)
        out[a:b] = res
    return out


def filtered_columns(signals: Signals, filters, x: np.ndarray) -> np.ndarray:
    """Every column of ``x`` through every filter of ``filters`` (column k through filter f in
    column k * len(filters) + f), per data segment, each filter starting at rest there; NaN
    outside the segments. The result is column-major: stacking long filtered columns side by
    side in a row-major array writes each with a stride, and on a week of 5 s data those
    copies cost more than the filters."""
    n, k = x.shape
    out = np.full((n, k * len(filters)), np.nan, order="F")
    for a, b in signals.segments:
        for c in range(k):
            column = np.ascontiguousarray(x[a:b, c])
            for f, g in enumerate(filters):
                out[a:b, c * len(filters) + f] = g.filter(column)
    return out


def valve_positions(signals: Signals, j: int, actuator: dict) -> np.ndarray:
    """Input j's valve position under ``actuator`` (the model file's actuator block), in
    absolute input units: the valve is simulated on the absolute OP of each segment (it starts
    at rest at each segment's first row); NaN outside the segments."""
    from .stiction.valve import valve_position

    op = signals.u[:, j] + signals.operating_point[signals.inputs[j]]
    return per_segment(signals, lambda x: valve_position(actuator, x), op)


def valve_input(signals: Signals, j: int, actuator: dict) -> np.ndarray:
    """Input j's deviation after the valve ``actuator`` (``valve_positions``), the position's
    mean over the segments as its operating point."""
    position = valve_positions(signals, j, actuator)
    return position - np.nanmean(position)
