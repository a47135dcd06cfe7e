"""A detector preset's durations at the data's sample time.

The presets (paper Tables 1 and 3, and the recommended ones derived from them) give their
window, step, inspection period and training in seconds, chosen at the paper's 5 s sampling.
At another sample time they are resolved so that the detector can run and each window still
holds enough data for the ARX-OE / residual regression:

* the window holds at least ``MIN_WINDOW_SAMPLES`` samples: when the preset's window holds
  fewer, window, step and inspection period are stretched by the same factor, so a window is
  still inspected over the preset's number of steps (n_T, eq. 23);
* the window holds at most ``MAX_WINDOW_SAMPLES`` samples (a shorter window in time at 1-2 s
  sampling; step and inspection period stay): with thousands of samples a window's Wald test
  resolves the small bias an unmeasured step or ramp disturbance leaves in closed loop, and
  takes it for a process change;
* the training period holds at least ``MIN_TRAINING_WINDOWS`` windows (Table 1's 3 h for 2 h
  windows), and never less than the preset's own;
* each duration is a whole number of samples (window and step to the nearest, at least one
  step; training rounded up), and the inspection period a whole number of steps.

At the paper's 5 s nothing changes (its windows hold 1440 samples). Fields a user sets explicitly
(``{"preset": "siso", "window_s": 14400}``) are kept verbatim: a user value that is not a whole
number of samples stays an error naming the field.
"""
from __future__ import annotations

import math

from ._core import DetectorConfig

__all__ = ["MAX_WINDOW_SAMPLES", "MIN_TRAINING_WINDOWS", "MIN_WINDOW_SAMPLES", "TIMING_FIELDS", "resolve_timing", "span_text"]

# Chosen on the tuning families (docs/detection.md "Presets at other sample times").
MIN_WINDOW_SAMPLES = 600
MAX_WINDOW_SAMPLES = 2700
MIN_TRAINING_WINDOWS = 1.5
TIMING_FIELDS = ("window_s", "step_s", "inspection_s", "train_duration_s")


def span_text(seconds: float) -> str:
    """A duration as people write it: 4 h, 2.5 h, 10 min, 45 s."""
    for unit, name in ((3600.0, "h"), (60.0, "min")):
        if seconds >= unit:
            return f"{seconds / unit:.4g} {name}"
    return f"{seconds:.4g} s"


def resolve_timing(config: DetectorConfig, preset: str, sample_time_s: float,
                   explicit=()) -> tuple[DetectorConfig, str | None]:
    """(config, note): `config` (the preset `preset` with the user's other fields) with the
    durations not in `explicit` resolved at `sample_time_s` (module docstring), and a one-line
    note saying what was resolved, or None when the preset's durations hold as they are."""
    ts = float(sample_time_s)
    if not (math.isfinite(ts) and ts > 0):
        raise ValueError(f"model: sample_time_s must be a positive number, got {sample_time_s}")
    given = {f: getattr(config, f) for f in TIMING_FIELDS}
    stretch = 1.0 if "window_s" in explicit else max(1.0, MIN_WINDOW_SAMPLES * ts / given["window_s"])
    steps_inspected = max(1, round(given["inspection_s"] / given["step_s"]))
    out = DetectorConfig.from_json(config.to_json())
    if "window_s" not in explicit:
        out.window_s = ts * min(max(MIN_WINDOW_SAMPLES, round(stretch * given["window_s"] / ts)),
                                max(MAX_WINDOW_SAMPLES, round(given["step_s"] / ts)))
    if "step_s" not in explicit:
        out.step_s = ts * max(1, round(stretch * given["step_s"] / ts))
    if "inspection_s" not in explicit:
        out.inspection_s = steps_inspected * out.step_s
    if "train_duration_s" not in explicit:
        training = max(given["train_duration_s"], MIN_TRAINING_WINDOWS * out.window_s)
        out.train_duration_s = ts * math.ceil(training / ts - 1e-9)
    out.validate()
    changed = [f for f in TIMING_FIELDS if abs(getattr(out, f) - given[f]) > 1e-9 * given[f]]
    if not changed:
        return out, None
    held = given["window_s"] / ts
    if stretch > 1:
        why = (f"its {span_text(given['window_s'])} window holds only {held:.4g} samples: windows stretched "
               f"x{stretch:.3g} to {MIN_WINDOW_SAMPLES} samples, training at least {MIN_TRAINING_WINDOWS:g} windows")
    elif held > MAX_WINDOW_SAMPLES and "window_s" not in explicit:
        why = (f"its {span_text(given['window_s'])} window would hold {held:.4g} samples: windows cut to "
               f"{MAX_WINDOW_SAMPLES} samples")
    else:
        why = "its durations rounded to whole samples"
    return out, (f"preset {preset} at {ts:g} s sampling: window {span_text(out.window_s)} = "
                 f"{round(out.window_s / ts)} samples, step {span_text(out.step_s)} = {round(out.step_s / ts)} "
                 f"samples, inspection {span_text(out.inspection_s)}, training {span_text(out.train_duration_s)} "
                 f"({why})")
