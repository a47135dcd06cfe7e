"""The data's own time: reading the times users type and writing the times results report.

Every command reads ``--train-end`` (and any other point in time) through ``Clock.when`` and
every duration option through ``parse_duration``, so ``6h``, ``90min``, ``3600`` (seconds from
the first sample) and ``2026-03-01T14:00:00+01:00`` mean the same in detect, diagnose, update
and compare. Results report times through ``Clock.stamp``: ISO-8601 timestamps when the file
has calendar time (timestamps or epoch seconds), hours since the first sample otherwise.

Inside the library time stays what ``load_data`` gives: the ``time`` column, seconds (from the
first sample for calendar time, as written for plain seconds).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone

from .timeaxis import seconds_of

_UNITS = {"ms": 1e-3, "s": 1.0, "sec": 1.0, "min": 60.0, "m": 60.0, "h": 3600.0, "hr": 3600.0,
          "d": 86400.0, "day": 86400.0, "days": 86400.0}
_DURATION = re.compile(r"^\s*([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*([a-z]*)\s*$")
_EPOCH = datetime(1970, 1, 1, tzinfo=timezone.utc)
# Points in time among the result fields (durations such as delay_s are left alone).
TIME_POINT_KEYS = ("start_s", "end_s", "onset_s", "onset_earliest_s", "onset_latest_s", "train_end_s")


def parse_duration(text, option: str = "duration") -> float:
    """Seconds of ``6h``, ``90min``, ``5s``, ``1.5d``, ``250ms`` or a bare number of seconds."""
    m = _DURATION.match(str(text).lower())
    if not m or m.group(2) not in ("", *_UNITS):
        raise ValueError(f"{option}: {text!r} is not a duration (e.g. 3600, 90min, 6h, 2d)")
    return float(m.group(1)) * _UNITS.get(m.group(2), 1.0)



@dataclass(frozen=True)
class Clock:
    """How the times of one data file read: its span, its calendar origin (if any)."""

    source: str
    start_s: float            # the first value of the ``time`` column
    end_s: float              # the last
    sample_time_s: float
    origin_epoch_s: float | None = None   # Unix time of time = 0; None for plain seconds
    # (time, UTC offset in s) from that time on, as the file writes its timestamps; None
    # for local time without an offset (and for plain seconds).
    utc_offsets: tuple | None = None

    @classmethod
    def of(cls, data, sample_time_s: float) -> "Clock":
        """The clock of a DataFrame from ``load_data`` (its ``attrs``)."""
        time = seconds_of(data)
        if len(time) == 0:
            raise ValueError(f"{data.attrs.get('source', 'data')}: no samples")
        attrs = data.attrs
        offsets = attrs.get("utc_offsets")
        return cls(str(attrs.get("source", "data")), float(time[0]), float(time[-1]), float(sample_time_s),
                   attrs.get("origin_epoch_s"), tuple(map(tuple, offsets)) if offsets else None)

    @property
    def calendar(self) -> bool:
        return self.origin_epoch_s is not None

    @property
    def duration_s(self) -> float:
        """n samples stand for n sample times."""
        return self.end_s - self.start_s + self.sample_time_s

    # ---- reading -----------------------------------------------------------------------

    def when(self, text, option: str = "--train-end") -> float:
        """A point in the data, on the ``time`` axis: a duration from the first sample (``6h``,
        ``90min``, ``3600``) or a timestamp. Outside the data is a ValueError naming its span."""
        text = str(text).strip()
        if re.match(r"^\d{4}-\d{2}-\d{2}", text):
            t = self._from_timestamp(text, option)
            typed = text
        else:
            t = self.start_s + parse_duration(text, option)
            typed = f"{text} ({self.hours(t)} from the start)"
        if not (self.start_s < t <= self.end_s + self.sample_time_s):
            raise ValueError(f"{option} {typed} is outside the data: {self.source} spans {self.span()}")
        return t

    def _from_timestamp(self, text: str, option: str) -> float:
        if not self.calendar:
            raise ValueError(f"{option} {text}: {self.source} has no timestamps (its time is seconds); "
                             "give a duration from the first sample such as 6h")
        try:
            when = datetime.fromisoformat(text.replace("Z", "+00:00"))
        except ValueError:
            raise ValueError(f"{option}: {text!r} is not an ISO-8601 timestamp") from None
        if when.tzinfo is not None:
            if self.utc_offsets is None:
                raise ValueError(f"{option} {text}: {self.source} has local times without a UTC offset; "
                                 "give the time without one")
            return (when - _EPOCH).total_seconds() - self.origin_epoch_s
        # A wall-clock time: in the offset the file uses at that time (the first that fits).
        wall = (when.replace(tzinfo=timezone.utc) - _EPOCH).total_seconds() - self.origin_epoch_s
        for offset in dict.fromkeys(o for _, o in self.utc_offsets or [(0.0, 0)]):
            if self._offset_at(wall - offset) == offset:
                return wall - offset
        return wall - self._offset_at(wall)

    # ---- writing -----------------------------------------------------------------------

    @property
    def offset_s(self) -> int | None:
        """The first row's UTC offset (None for local time)."""
        return None if self.utc_offsets is None else self.utc_offsets[0][1]

    def _offset_at(self, t: float) -> int:
        offset = self.utc_offsets[0][1] if self.utc_offsets else 0
        for start, value in self.utc_offsets or ():
            if start <= t:
                offset = value
        return offset

    def datetime(self, t: float) -> datetime:
        """The calendar time of ``t`` in the UTC offset the file uses then; naive for local time."""
        when = _EPOCH + timedelta(seconds=self.origin_epoch_s + t)
        when = when.astimezone(timezone(timedelta(seconds=self._offset_at(t))))
        return when.replace(tzinfo=None) if self.utc_offsets is None else when

    def hours(self, t: float) -> str:
        return f"{(t - self.start_s) / 3600:.2f} h"

    def stamp(self, t: float) -> str:
        """``t`` as a user reads it: a timestamp, or hours since the first sample."""
        if t is None or not math.isfinite(t):
            return "-"
        if not self.calendar:
            return self.hours(t)
        text = self.datetime(t).isoformat(timespec="milliseconds" if t % 1 else "seconds")
        return text.replace("+00:00", "Z")

    def span(self) -> str:
        return self.span_between(self.start_s, self.end_s + self.sample_time_s)

    def span_between(self, a: float, b: float) -> str:
        """``a .. b (hours)``; plain-seconds data read in hours since the first sample."""
        return f"{self.stamp(a)} .. {self.stamp(b)} ({(b - a) / 3600:.4g} h)"

    def to_dict(self) -> dict:
        """The ``time`` block of the JSON outputs."""
        return {"kind": "calendar" if self.calendar else "seconds", "start": self.stamp(self.start_s),
                "end": self.stamp(self.end_s), "start_s": self.start_s, "end_s": self.end_s,
                "utc_offsets": [list(c) for c in self.utc_offsets] if self.utc_offsets else None}

    def stamp_fields(self, doc):
        """A copy of a result document with a timestamp beside every point in time
        (``onset_s`` gets ``onset``, ...); unchanged for plain seconds."""
        if not self.calendar:
            return doc
        if isinstance(doc, list):
            return [self.stamp_fields(x) for x in doc]
        if not isinstance(doc, dict):
            return doc
        out = {}
        for key, value in doc.items():
            out[key] = self.stamp_fields(value)
            if key in TIME_POINT_KEYS and isinstance(value, (int, float)):
                out[key[:-2]] = self.stamp(value)
        return out

