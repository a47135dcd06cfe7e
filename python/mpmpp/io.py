"""The user's files (docs/formats.md): the model (JSON) and the operating data (CSV).

Reading, validation and writing are done by the C++ engine, so the Python
package and a C++ program linking ``mpmpp::mpmpp`` accept exactly the same files.
Every problem is a ``ValueError`` whose message is one line naming the file and
the field, column or row at fault.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from typing import TYPE_CHECKING, Optional, Sequence, Union

import numpy as np

from . import _core
from ._core import Model

if TYPE_CHECKING:
    import pandas as pd

PathLike = Union[str, "os.PathLike[str]"]

__all__ = ["Model", "load_model", "save_model", "load_data", "load_loop_data", "save_data", "atomic_output"]


def load_model(path: PathLike) -> Model:
    """Read and validate a model file; FOPTD channels are discretised at its sample time."""
    return _core.load_model(os.fspath(path))


def save_model(model: Model, path: PathLike) -> None:
    """Write ``model`` in the discrete form (atomically: a reader never sees half a file)."""
    _core.save_model(model, os.fspath(path))


def load_data(path: PathLike, model: Optional[Model] = None, *, max_gap_s: Optional[float] = None,
              resample_s: Optional[float] = None, quality_column: Optional[str] = None,
              good_quality: Sequence[str] = (), jitter_fraction: float = 0.25) -> pd.DataFrame:
    """Read a data file into a DataFrame: a ``time`` column in seconds, then every numeric column.

    Without a model the rows are taken as written (time strictly increasing). With a
    ``model``, the rows are put on its sample grid (docs/files.md "Historian exports"):
    timestamps within ``jitter_fraction`` of a sample time are snapped, exact repeats
    dropped, gaps up to ``max_gap_s`` (default 10 sample times) filled with missing rows,
    longer gaps split the record (one missing row marks each split); ``quality_column``
    masks rows that are not good (``good_quality``: the good codes); ``resample_s`` block-
    averages faster data to the model's sample time. Its inputs and outputs must be numeric
    columns. Missing cells are NaN (never interpolated).

    ``df.attrs``: ``source`` (the path), ``missing`` (count per column), ``time_origin`` (the
    first timestamp as written, None for plain seconds), ``origin_epoch_s`` (Unix time of
    time 0 for calendar time: timestamps or epoch seconds, time then counts seconds from
    the first sample; None for plain seconds), ``utc_offsets`` (the UTC offsets the timestamps
    carry, ``[(time, offset_s), ...]`` from each time on: more than one across a daylight-saving
    change; None for local timestamps and plain seconds), ``text_columns`` (columns without numbers, not
    data), ``segment_starts`` (rows starting a segment after a split) and ``repairs``
    (what was repaired, as a dict; see ``repairs_dict``).
    """
    import pandas as pd  # here, not at the top: `import mpmpp` stays fast for model-only work

    path = os.fspath(path)
    if model is None:
        if max_gap_s is not None or resample_s or quality_column:
            raise ValueError(f"{path}: gaps, resampling and quality need the model's sample time")
        table = _core.read_csv(path)
    else:
        options = _core.LoadOptions(max_gap_s=-1.0 if max_gap_s is None else float(max_gap_s),
                                    jitter_fraction=float(jitter_fraction), resample_s=float(resample_s or 0.0),
                                    quality_column=quality_column or "", good_quality=list(good_quality))
        table = _core.load_data(path, model, options)
    columns = {"time": np.asarray(table.time_s)}
    values = np.asarray(table.values)
    for k, name in enumerate(table.columns):
        columns[name] = values[:, k]
    df = pd.DataFrame(columns)
    calendar = table.time_kind != _core.TimeKind.seconds
    df.attrs.update(
        source=path,
        missing=dict(zip(table.columns, table.missing)),
        time_origin=table.time_origin or None,
        origin_epoch_s=table.origin_epoch_s if calendar else None,
        utc_offsets=[tuple(c) for c in table.utc_offsets]
        if table.time_kind in (_core.TimeKind.timestamp, _core.TimeKind.epoch_seconds) else None,
        text_columns=list(table.text_columns),
        segment_starts=list(table.segment_starts),
        repairs=repairs_dict(table.repairs),
    )
    return df


def load_loop_data(path: PathLike, columns: Sequence[str], *, max_gap_s: Optional[float] = None,
                   resample_s: Optional[float] = None, quality_column: Optional[str] = None,
                   good_quality: Sequence[str] = ()) -> pd.DataFrame:
    """A data file for the commands that have no model yet (``identify``, ``stiction``): put on
    the grid of its own sample time (``sample_time_of`` the times as written; ``resample_s`` when given) with
    ``load_data``'s historian repairs, ``columns`` required numeric. A timestamp's jitter, a gap
    and a bad-quality row are then what they are for ``diagnose`` on the same file."""
    # the rows as written: an export's repeated rows (a chunk boundary) are dropped by the
    # repairs below, as for diagnose, not refused by a check of strictly increasing time
    rows = _core.read_csv_rows(os.fspath(path))
    for name in columns:
        if name not in [*rows.columns, *rows.text_columns] or name == "time":
            raise ValueError(f"{os.fspath(path)}: no column {name!r} (columns: {', '.join(rows.columns)})")
    sample_time_s = float(resample_s) if resample_s else sample_time_of(np.unique(np.asarray(rows.time_s)))
    if not sample_time_s > 0:
        raise ValueError(f"{os.fspath(path)}: needs at least 2 rows with increasing times")
    columns = list(dict.fromkeys(columns))  # checked numeric by the grid "model": no channels, only names
    grid = _core.Model("sample grid", sample_time_s, columns[:-1], columns[-1:], {}, {})
    return load_data(path, grid, max_gap_s=max_gap_s, resample_s=resample_s, quality_column=quality_column,
                     good_quality=good_quality)


def sample_time_of(time_s: np.ndarray) -> float:
    """The sample time of timestamps as a historian writes them: each step counted in whole
    samples of the median step (a gap is several), the least-squares slope of the times over
    those counts (the median of jittered steps can be off by a hundredth of a sample, which
    drifts a 2 h record off its grid; the slope's error shrinks as jitter / N^1.5), then the
    roundest value that keeps the drift over the record within 5 % of a sample or twice the
    steps' own jitter (10 s, not 10.0004 s). 0 without two increasing times."""
    time_s = np.asarray(time_s, dtype=float)
    steps = np.diff(time_s)
    if len(steps) == 0 or not np.median(steps) > 0:
        return 0.0
    median = float(np.median(steps))
    counts = np.r_[0.0, np.cumsum(np.maximum(np.round(steps / median), 1.0))]
    slope = float(np.polyfit(counts, time_s, 1)[0])
    drift = max(0.05 * slope, 2 * 1.4826 * float(np.median(np.abs(steps - median))))
    for digits in range(10):
        nice = round(slope, digits - int(np.floor(np.log10(slope))))
        if nice > 0 and abs(nice - slope) * counts[-1] <= drift:
            return float(nice)
    return slope


def repairs_dict(repairs) -> dict:
    """The engine's DataRepairs as plain data (for JSON and ``check``)."""
    return {
        "jitter_snapped": repairs.jitter_snapped,
        "max_jitter_s": repairs.max_jitter_s,
        "duplicates_dropped": repairs.duplicates_dropped,
        "gaps": [{"start_s": g.start_s, "end_s": g.end_s, "missing_rows": g.missing_rows, "split": g.split}
                 for g in repairs.gaps],
        "bad_quality_rows": repairs.bad_quality_rows,
        "text_columns": list(repairs.text_columns),
        "status_words": [{"column": w.column, "cells": w.cells, "first": w.first} for w in repairs.status_words],
        "resample_factor": repairs.resample_factor,
        "raw_sample_time_s": repairs.raw_sample_time_s or None,
    }


def save_data(path: PathLike, df: pd.DataFrame) -> None:
    """Write a DataFrame with a ``time`` column (seconds) as a data file, atomically.

    Numbers are written in their shortest exact form, so ``load_data`` gives back the
    same values; NaN becomes an empty cell.
    """
    if "time" not in df.columns:
        raise ValueError(f"{os.fspath(path)}: the DataFrame has no 'time' column")
    names = [str(c) for c in df.columns if c != "time"]
    try:
        time_s = df["time"].to_numpy(dtype=float)
        values = df[[c for c in df.columns if c != "time"]].to_numpy(dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{os.fspath(path)}: every column must be numeric ({exc})") from None
    try:
        table = _core.DataTable(time_s, names, values.reshape(len(df), len(names)))
    except ValueError as exc:
        raise ValueError(f"{os.fspath(path)}: {exc}") from None
    _core.write_csv(table, os.fspath(path))


def json_safe(obj):
    """JSON has no NaN: non-finite floats become None, through dicts and lists."""
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [json_safe(v) for v in obj]
    return obj


@contextlib.contextmanager
def atomic_output(path: PathLike, mode: str = "w"):
    """An open temporary file beside ``path`` that replaces ``path`` (fsync, then rename) only
    when the block succeeds: an interrupted or failed write leaves the previous file intact.
    For files written in Python; the engine's save_model/save_data do the same in C++."""
    path = os.fspath(path)
    folder = os.path.dirname(path) or "."
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(path)}.tmp.", dir=folder)
    except OSError as exc:   # named by the file asked for, not by the temporary one
        raise type(exc)(f"{path}: cannot write in {folder}: {exc.strerror}") from None
    try:
        with os.fdopen(fd, mode) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, os.stat(path).st_mode & 0o7777 if os.path.exists(path) else 0o644)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
