"""Times as engineers read them: in the data's own clock when it has one, else as durations.

Analyses count time in seconds (``data["time"]``). A data file with timestamps carries its
first timestamp as ``data.attrs["time_origin"]``; then second t is the moment
origin + t. Without one, seconds are the file's own numbers. These helpers turn seconds
into what a figure axis or a table shows, so every output speaks the same time.
"""
from __future__ import annotations

import math
from typing import Optional, Sequence

import numpy as np

__all__ = ["sample_grid", "seconds_of", "origin_of", "absolute_seconds", "format_duration", "format_moment",
           "plot_axis", "shade_training", "mark_alarms"]


def seconds_of(data) -> np.ndarray:
    """The ``time`` column of a DataFrame as float seconds, finite and increasing. A frame
    without one, a column of timestamps (datetime64) or text, and rows out of time order or
    repeated are one-line ValueErrors naming it, as the file reader's are: read as floats,
    timestamps would count nanoseconds and every duration would be off by 1e9, and rows out of
    order were analysed as if in order."""
    if "time" not in getattr(data, "columns", ()):
        raise ValueError("data: no 'time' column (seconds; a frame indexed by time: data.reset_index())")
    column = data["time"]
    if getattr(column.dtype, "kind", "") == "M":
        raise ValueError("data: column 'time' holds timestamps; analyses count seconds (mpmpp.load_data "
                         "reads a timestamped file into seconds, or set data['time'] = "
                         "(t - t.iloc[0]).dt.total_seconds())")
    try:
        time_s = column.to_numpy(dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"data: column 'time' must be numbers of seconds, got {column.iloc[0]!r}") from None
    if not np.all(np.isfinite(time_s)):
        raise ValueError(f"data: column 'time' row {int(np.flatnonzero(~np.isfinite(time_s))[0])}: "
                         "not a finite number of seconds")
    back = np.flatnonzero(np.diff(time_s) <= 0)
    if len(back):
        k = int(back[0]) + 1
        raise ValueError(f"data: column 'time' row {k}: {time_s[k]:g} s is not after row {k - 1}'s {time_s[k - 1]:g} s "
                         "(rows must be in time order, each time once)")
    return time_s


def sample_grid(time_s: np.ndarray, splits=()) -> tuple[float, np.ndarray]:
    """(ts, starts): the time column's typical step, and the rows that follow a gap (a whole
    number of samples missing: a historian export leaves such rows out). Historian exports round
    timestamps: 0.1 % slack. A step that is no whole number of samples is an error naming it,
    except around a split ``load_data`` made (``splits``: its ``segment_starts``; the missing row
    before each marks the split, and the steps into it and out of it are free)."""
    if len(time_s) < 2 or not np.all(np.isfinite(time_s)):
        raise ValueError("data: the 'time' column needs at least 2 finite values")
    steps = np.diff(time_s)
    free = np.zeros(len(steps), dtype=bool)
    for s in splits:   # step k leads into row k + 1
        free[max(int(s) - 2, 0):int(s)] = True
    ts = float(np.median(steps[~free])) if np.any(~free) else float(np.median(steps))
    whole = np.round(steps / ts) if ts > 0 else steps
    bad = np.flatnonzero(~free & ((whole < 1) | (np.abs(steps - whole * ts) > 1e-3 * ts)))
    if ts <= 0 or len(bad):
        row = int(bad[0]) + 1 if len(bad) else 1
        raise ValueError(f"data: 'time' is not evenly spaced (step {steps[row - 1]:g} s at row {row}, "
                         f"typical {ts:g} s, and not a whole number of samples)")
    return ts, np.flatnonzero(free | (whole > 1)) + 1


def origin_of(data_or_origin) -> Optional["np.datetime64"]:
    """The first timestamp (numpy datetime64, UTC) of a DataFrame from ``load_data`` or of an
    ISO-8601 text / datetime; None when the data's time is plain seconds."""
    import pandas as pd

    if hasattr(data_or_origin, "attrs"):
        epoch = data_or_origin.attrs.get("origin_epoch_s")  # calendar time of any kind (ISO or epoch)
        if epoch is not None:
            return np.datetime64(int(round(float(epoch) * 1000)), "ms")
        origin = data_or_origin.attrs.get("time_origin")
    else:
        origin = data_or_origin
    if origin is None or (isinstance(origin, str) and not origin.strip()):
        return None
    try:
        stamp = pd.Timestamp(origin)
    except (ValueError, TypeError):
        raise ValueError(f"time origin: cannot read {origin!r} as a timestamp") from None
    if stamp.tzinfo is not None:
        stamp = stamp.tz_convert("UTC").tz_localize(None)
    return np.datetime64(stamp.to_datetime64(), "ms")


def absolute_seconds(time_s, origin) -> np.ndarray:
    """Seconds on a clock shared by files with different first samples: epoch seconds when
    the data has timestamps (origin), else the file's own seconds."""
    t = np.asarray(time_s, dtype=float)
    if origin is None:
        return t
    return t + (origin - np.datetime64("1970-01-01T00:00:00", "ms")) / np.timedelta64(1, "s")


def format_duration(seconds: float) -> str:
    """'45 s', '12 min', '9 h 35 min', '2 d 3 h': never '9.58333 h'."""
    if not math.isfinite(seconds):
        return str(seconds)
    sign, s = ("-" if seconds < 0 else ""), abs(seconds)
    if s < 120:
        return f"{sign}{s:.0f} s" if s == round(s) else f"{sign}{s:.1f} s"
    minutes = int(round(s / 60))
    if minutes < 60:
        return f"{sign}{minutes} min"
    hours, minutes = divmod(minutes, 60)
    if hours < 48:
        return f"{sign}{hours} h" + (f" {minutes:02d} min" if minutes else "")
    days, hours = divmod(hours, 24)
    return f"{sign}{days} d" + (f" {hours} h" if hours else "")


def format_moment(time_s: float, origin=None, start_s: Optional[float] = None) -> str:
    """A moment of the data: its timestamp ('2024-03-01 09:35:00 UTC') when the data has
    one, else 't = 34500 s (9 h 35 min after the first sample)'."""
    if origin is not None:
        stamp = origin + np.timedelta64(int(round(time_s * 1000)), "ms")
        return str(stamp.astype("datetime64[s]")).replace("T", " ") + " UTC"
    text = f"t = {time_s:g} s"
    if start_s is not None:
        text += f" ({format_duration(time_s - start_s)} after the first sample)"
    return text


def plot_axis(time_s: Sequence[float], origin=None, start_s: Optional[float] = None):
    """(x values, axis label, converter) for a time axis: datetimes when the data has
    timestamps; else time since ``start_s`` (default: the first value) in hours, or in
    minutes for records under 5 h. ``converter`` maps further seconds onto the same axis."""
    t = np.asarray(time_s, dtype=float)
    if origin is not None:
        import matplotlib.dates as mdates
        import matplotlib.units as munits

        # Concise date ticks ('06:00', 'Mar 01') instead of full timestamps that overlap.
        munits.registry[np.datetime64] = mdates.ConciseDateConverter()

        def convert(s):
            ms = np.round(np.asarray(s, dtype=float) * 1000).astype(np.int64)
            return origin + ms.astype("timedelta64[ms]")
        return convert(t), "time (UTC)", convert
    t0 = float(start_s) if start_s is not None else (float(t[0]) if t.size else 0.0)
    span = float(np.nanmax(t) - t0) if t.size else 0.0
    scale, unit = (3600.0, "h") if span >= 5 * 3600 else (60.0, "min")
    label = f"time since the first sample ({unit})" if t0 != 0 else f"time ({unit})"

    def convert(s):
        return (np.asarray(s, dtype=float) - t0) / scale
    return convert(t), label, convert


def shade_training(ax, start_s: float, end_s: float, convert, label: bool = True) -> None:
    """The training period as a grey band (the data assumed free of mismatch there)."""
    lo, hi = convert(start_s), convert(end_s)
    ax.axvspan(lo, hi, color="0.85", alpha=0.6, lw=0, label="training period" if label else None, zorder=0)


def mark_alarms(ax, starts_s: Sequence[float], convert, text: bool = True, origin=None, start_s=None) -> None:
    """Red lines at alarm starts, each labelled with its time on the top edge."""
    for k, s in enumerate(starts_s):
        x = convert(s)
        ax.axvline(x, color="tab:red", lw=1.2, label="alarm starts" if k == 0 else None)
        if text:
            when = format_moment(s, origin)[:16] if origin is not None else format_duration(s - (start_s or 0.0))
            ax.annotate(f"alarm {when}", xy=(x, 1.0), xycoords=("data", "axes fraction"), xytext=(2, -2),
                        textcoords="offset points", fontsize=7, color="tab:red", va="top", ha="left")
