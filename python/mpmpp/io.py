"""The user's files (FORMATS.md): the model (JSON) and the operating data (CSV).

Reading, validation and writing are done by the C++ engine, so the Python
package and a C++ program linking ``mpmpp::mpmpp`` accept exactly the same files.
Every problem is a ``ValueError`` whose message is one line naming the file and
the field, column or row at fault.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from typing import TYPE_CHECKING, Optional, Union

import numpy as np

from . import _core
from ._core import Model

if TYPE_CHECKING:
    import pandas as pd

PathLike = Union[str, "os.PathLike[str]"]

__all__ = ["Model", "load_model", "save_model", "load_data", "save_data", "atomic_output"]


def load_model(path: PathLike) -> Model:
    """Read and validate a model file; FOPTD channels are discretised at its sample time."""
    return _core.load_model(os.fspath(path))


def save_model(model: Model, path: PathLike) -> None:
    """Write ``model`` in the discrete form (atomically: a reader never sees half a file)."""
    _core.save_model(model, os.fspath(path))


def load_data(path: PathLike, model: Optional[Model] = None) -> pd.DataFrame:
    """Read a data file into a DataFrame: a ``time`` column in seconds, then every CSV column.

    With a ``model``, its inputs and outputs must be columns and the time step must equal
    ``model.sample_time_s``. Missing cells are NaN (never interpolated); ``df.attrs`` holds
    ``missing`` (count per column), ``time_origin`` (the first timestamp for ISO-8601 time,
    time then counts seconds from it; None for numeric time) and ``source`` (the path).
    """
    import pandas as pd  # here, not at the top: `import mpmpp` stays fast for model-only work

    path = os.fspath(path)
    table = _core.read_csv(path) if model is None else _core.load_data(path, model)
    columns = {"time": np.asarray(table.time_s)}
    values = np.asarray(table.values)
    for k, name in enumerate(table.columns):
        columns[name] = values[:, k]
    df = pd.DataFrame(columns)
    df.attrs["missing"] = dict(zip(table.columns, table.missing))
    df.attrs["time_origin"] = table.time_origin or None
    df.attrs["source"] = path
    return df


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


@contextlib.contextmanager
def atomic_output(path: PathLike, mode: str = "w"):
    """An open temporary file beside ``path`` that replaces ``path`` (fsync, then rename) only
    when the block succeeds: an interrupted or failed write leaves the previous file intact.
    For files written in Python; the engine's save_model/save_data do the same in C++."""
    path = os.fspath(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(path)}.tmp.", dir=os.path.dirname(path) or ".")
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
