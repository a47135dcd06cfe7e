"""Plant-side monitoring of new data with a saved detector (``mpmpp monitor``).

``monitor(detector_path, data_path, checkpoint)`` pushes the data file's samples into a
StreamingDetector (the C++ plant path, bit-identical to ``detect``'s batch windows). With a
checkpoint the run is resumable: the stream state is restored from it, rows the stream has
already taken (time at or before its last sample) are passed over, and the new state is
written back atomically, so monitoring a growing historian export run after run gives the
alarms of one run on all the data. Alarm times are the window end, in the data's own time.
"""
from __future__ import annotations

import json
import os
import re
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from . import _core
from .detect import _arrays, _channel_dicts, channel_label
from .clock import Clock
from .timeaxis import absolute_seconds, origin_of

__all__ = ["MonitorResult", "monitor", "monitor_loop"]


@dataclass
class MonitorResult:
    """What one monitoring run saw (see ``to_dict`` for the JSON form)."""

    detector: str
    data: str
    channels: list                 # dicts: kind, output[, input]
    alarms: list                   # dicts: kind, output[, input], channel, start_s
    active: list                   # per channel: alarm on after the last window
    windows: int                   # windows completed in this run
    skipped_windows: list          # dicts: start_s, end_s, reason
    new_samples: int               # rows taken in this run
    passed_over: int               # rows already taken by an earlier run (checkpoint)
    total_samples: int             # since the stream's first sample
    last_time_s: Optional[float]   # the last sample taken (data seconds), None if none yet
    clock: Optional[Clock] = None  # the data's own time (timestamps in results, as every command)
    last_window: Optional[dict] = field(default=None)  # end_s, scores, indicator of the last window

    def stamp(self, t: float) -> str:
        return self.clock.stamp(t) if self.clock is not None else f"t = {t:g} s"

    def to_dict(self) -> dict:
        """The ``monitor --json`` document: times in the data's own time, as every command
        writes them (a ``time`` block, a timestamp beside each ``*_s`` point)."""
        last = None if self.last_time_s is None else self.stamp(self.last_time_s)
        doc = {"detector": self.detector, "data": self.data, "channels": self.channels,
                "alarms": [{k: v for k, v in a.items() if k != "channel"} for a in self.alarms],
                "alarm_active": [{**c, "active": bool(on)} for c, on in zip(self.channels, self.active)],
                "windows": self.windows, "skipped_windows": self.skipped_windows,
                "new_samples": self.new_samples, "passed_over": self.passed_over,
                "total_samples": self.total_samples, "last_sample": last}
        if self.clock is None:
            return doc
        return {**self.clock.stamp_fields(doc), "time": self.clock.to_dict()}

    def summary(self) -> str:
        lines = [f"{self.data}: {self.new_samples} new samples"
                 + (f" ({self.passed_over} already monitored)" if self.passed_over else "")
                 + f", {self.windows} windows"
                 + (f", {len(self.skipped_windows)} skipped" if self.skipped_windows else "")]
        if self.alarms:
            width = max(len(channel_label(a)) for a in self.alarms)
            lines.append("alarms that started:")
            for a in self.alarms:
                kind = "model-plant mismatch" if a["kind"] == "process" else "noise change"
                lines.append(f"  {channel_label(a):<{width}}  {kind:<20}  {self.stamp(a['start_s'])}")
        else:
            lines.append("no alarm started")
        on = [channel_label(c) for c, a in zip(self.channels, self.active) if a]
        lines.append("alarm active now: " + (", ".join(on) if on else "none"))
        return "\n".join(lines)


def _rows_to_take(abs_time: np.ndarray, stream) -> int:
    """Index of the first row the stream has not taken yet (0 for a fresh stream)."""
    if stream.samples == 0:
        return 0
    last = json.loads(stream.checkpoint_json())["last_time"]
    # Rows at or before the last sample taken (half a sample of tolerance for jitter).
    half = 0.5 * stream.detector.model.sample_time_s
    return int(np.searchsorted(abs_time, last + half, side="left"))


def monitor(detector, data, checkpoint: Optional[str] = None) -> MonitorResult:
    """Monitors ``data`` (a path or a DataFrame from ``load_data``) with ``detector`` (a
    detector file path). ``checkpoint``: resume from this file when it exists, save the
    stream state there afterwards (atomically)."""
    from . import load_data
    from .stream import StreamingDetector

    stream = StreamingDetector(detector)
    core = stream._core
    model = core.detector.model
    if isinstance(data, (str, os.PathLike)):
        data_name = os.fspath(data)
        data = load_data(data_name, model)
    else:
        data_name = str(data.attrs.get("source", "data"))
    if checkpoint is not None and os.path.exists(checkpoint):
        stream.load_checkpoint(checkpoint)
    origin = origin_of(data)
    time_s, u, y = _arrays(model, data)
    # The stream counts time on the clock it started with; timestamps go on an absolute
    # clock so a later file holding only the new rows continues the same stream.
    abs_time = absolute_seconds(time_s, origin)
    first = _rows_to_take(abs_time, stream)
    try:
        windows = stream.push_block(abs_time[first:], u[first:], y[first:]) if first < len(abs_time) else []
    except ValueError as exc:
        # The block's row numbers as the file's line numbers (header = line 1).
        text = re.sub(r"push_block: row (\d+)", lambda m: f"line {first + int(m.group(1)) + 2}", str(exc))
        raise ValueError(f"{data_name}: {text}") from None
    shift = abs_time[0] - time_s[0] if len(time_s) else 0.0   # back to the file's seconds
    channels = _channel_dicts(model, _core.WindowFeatures(model, core.detector.config).channels)
    alarms, skipped = [], []
    for w in windows:
        if w.skipped:
            skipped.append({"start_s": w.start_s - shift, "end_s": w.end_s - shift, "reason": w.skip_reason})
        for k in w.alarm_starts:
            alarms.append({**channels[k], "channel": int(k), "start_s": w.end_s - shift})
    if checkpoint is not None:
        stream.save_checkpoint(checkpoint)
    last = windows[-1] if windows else None
    return MonitorResult(
        detector=os.fspath(detector), data=data_name, channels=channels, alarms=alarms,
        active=list(stream.alarm), windows=len(windows), skipped_windows=skipped,
        new_samples=max(len(abs_time) - first, 0), passed_over=first, total_samples=int(stream.samples),
        last_time_s=float(time_s[-1]) if len(time_s) else None,
        clock=Clock.of(data, model.sample_time_s) if len(time_s) else None,
        last_window=None if last is None else {"end_s": last.end_s - shift, "scores": [float(v) for v in last.scores],
                                                "indicator": [float(v) for v in last.indicator]})


def monitor_loop(name: str, detector: str, data: str, checkpoint: Optional[str] = None) -> dict:
    """One loop of a fleet: its summary row as plain data (picklable, for any worker). A bad
    file makes the row's status 'error' with the message instead of stopping the fleet."""
    try:
        r = monitor(detector, data, checkpoint)
    except (ValueError, OSError) as exc:
        return {"loop": name, "status": "error", "message": str(exc)}
    active = [channel_label(c) for c, on in zip(r.channels, r.active) if on]
    first = r.alarms[0] if r.alarms else None
    return {"loop": name, "status": "ALARM" if active else "ok", "active": active,
            "alarms": len(r.alarms),
            "first_alarm": None if first is None else f"{channel_label(first)} {r.stamp(first['start_s'])}",
            "windows": r.windows, "skipped": len(r.skipped_windows), "samples": r.new_samples,
            "last_sample": r.to_dict()["last_sample"], "message": ""}
