"""A model column that stops moving: frozen for the whole record (a tag the historian stopped
updating, a stuck transmitter or valve) or held at one value for an hour or more (at a limit, in
manual). Nothing about a channel through it can be learnt where it does not move, and every
analysis says so rather than reading the model as right (docs/diagnose.md "Frozen inputs").
Beside it, the columns no analysis can use at all: never recorded, or holding a value beyond
what floating point computes with."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .signals import Signals


def frozen(x: np.ndarray) -> bool:
    """Whether a column holds one value wherever it is known: a tag the historian stopped
    updating, or a transmitter or valve stuck for the whole record. Nothing about a channel
    through it can be learnt from the record."""
    known = np.asarray(x, dtype=float)
    known = known[np.isfinite(known)]
    return len(known) > 0 and bool(np.all(known == known[0]))


def require_recorded_columns(inputs, u: np.ndarray, outputs, y: np.ndarray) -> None:
    """ValueError naming the first model column without a single value (a tag the export
    left empty): it used to surface as 'no stretch of rows without missing values' or as a
    training period without usable windows. (A monitored chunk may lack a tag for a while:
    ``monitor`` skips those windows and does not call this.)"""
    for kind, names, columns in (("input", inputs, u), ("output", outputs, y)):
        for name, column in zip(names, np.asarray(columns, dtype=float).T):
            if len(column) and not np.isfinite(column).any():
                raise ValueError(f"data: column '{name}' (model {kind}) has no values: all {len(column)} rows "
                                 "are missing")


def require_computable(names, columns: np.ndarray, time_s: np.ndarray | None = None) -> None:
    """ValueError naming the first column (of ``columns``, N x len(names)) with a value of
    magnitude LARGEST_VALUE or more, infinities included, and where (at ``time_s``, or the row).
    The file reader refuses such a cell (data_io.hpp kLargestValue); this is the same rule for
    arrays and data frames, where an infinity would otherwise pass for a missing value."""
    from ._core import LARGEST_VALUE   # here: `mpmpp check -h` loads this module, not the engine

    for name, column in zip(names, np.asarray(columns, dtype=float).T):
        beyond = np.flatnonzero(np.abs(column) >= LARGEST_VALUE)
        if len(beyond):
            k = beyond[0]
            where = f"row {k}" if time_s is None else f"t={time_s[k]:g} s"
            raise ValueError(f"data: column '{name}' holds {column[k]:.4g} at {where}: a value of magnitude "
                             f"{LARGEST_VALUE:g} or more cannot be computed with (its squares overflow); check "
                             "the column's units")


def require_moving_outputs(names, y: np.ndarray) -> None:
    """ValueError naming the first model output (column of y) that is ``frozen``: nothing about
    the model can be checked against an output that never moves."""
    for name, column in zip(names, np.asarray(y, dtype=float).T):
        if frozen(column):
            value = column[np.isfinite(column)][0]
            raise ValueError(f"data: output '{name}' has one value throughout the record ({value:g}): a frozen tag "
                             "or a stuck transmitter leaves nothing to check the model against (leave the output "
                             "out of the model file, or bring a record where it moves)")


def frozen_note(name: str) -> str:
    """The note every analysis gives for a ``frozen`` model input."""
    return (f"{name}: one value throughout the record (a frozen tag or a stuck signal): the channels from it "
            "cannot be checked on these data")


def frozen_columns(names, columns: np.ndarray) -> list[str]:
    """The names of the ``frozen`` columns of ``columns`` (rows x names)."""
    return [name for name, x in zip(names, np.asarray(columns, dtype=float).T) if frozen(x)]


def frozen_inputs(sig: Signals, i: int | None = None) -> list[str]:
    """The model inputs (of output i's channels, or all) that are ``frozen`` in the record."""
    return [name for name in frozen_columns(sig.inputs, sig.u)
            if i is None or sig.rows[i][sig.inputs.index(name)] is not None]


def unchecked_inputs(sig: Signals, i: int, start: int) -> list[str]:
    """The inputs of output i's channels that are ``frozen``, or from row ``start`` on held at one
    value (``held_stretches``) over most of the rest: their channels are not tested there."""
    rows = held_stretch_rows(sig.sample_time_s)
    return [name for j, name in enumerate(sig.inputs) if sig.rows[i][j] is not None
            and (frozen(sig.u[:, j]) or held_rows(sig.u[start:, j], rows).mean() > 0.5)]


# A model input that holds one value this long (manual mode with a fixed OP, a stuck valve, a
# tag the historian stopped updating) is named: nothing about its channels is seen there.
HELD_STRETCH_S = 3600.0


def held_stretch_rows(sample_time_s: float) -> int:
    """HELD_STRETCH_S in rows."""
    return max(int(round(HELD_STRETCH_S / sample_time_s)), 2)


def held_stretches(x: np.ndarray, min_rows: int) -> list[tuple[int, int]]:
    """The row ranges [a, b) of at least ``min_rows`` rows over which x holds one value
    (a missing value ends a stretch)."""
    x = np.asarray(x, dtype=float)
    same = np.concatenate([[False], np.isfinite(x[1:]) & (x[1:] == x[:-1]), [False]])
    # same[k]: rows k - 1 and k are equal; a run of them over k = a + 1 .. b covers rows a .. b
    edges = np.flatnonzero(np.diff(same.astype(np.int8)))
    return [(int(a), int(b) + 1) for a, b in zip(edges[::2], edges[1::2]) if b + 1 - a >= min_rows]


def held_columns(names, columns: np.ndarray, sample_time_s: float) -> dict[str, list[tuple[int, int]]]:
    """Name -> the ``held_stretches`` of an hour or more of each column of ``columns`` (rows x
    names); columns frozen throughout, or with no such stretch, left out."""
    rows = held_stretch_rows(sample_time_s)
    held = {name: held_stretches(x, rows) for name, x in zip(names, np.asarray(columns, dtype=float).T)
            if not frozen(x)}
    return {name: stretches for name, stretches in held.items() if stretches}


def held_rows(x: np.ndarray, min_rows: int) -> np.ndarray:
    """Per row: inside one of x's ``held_stretches``."""
    held = np.zeros(len(x), bool)
    for a, b in held_stretches(x, min_rows):
        held[a:b] = True
    return held


def held_note(sig: Signals, name: str, stretch: tuple[int, int]) -> str:
    """The note for a model input held at one value over ``stretch`` (not the whole record)."""
    a, b = stretch
    t = sig.time_s
    return (f"{name}: one value from t={t[a] / 3600:.2f} h to t={t[b - 1] / 3600:.2f} h ({(b - a) * sig.sample_time_s / 3600:.1f} h: "
            "at a limit, in manual, a stuck valve or a stale tag): no channel from it is checked there")
