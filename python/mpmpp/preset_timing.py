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

``fit_to_record`` then fits them to the record ``detect`` monitors (a historian export of a few
hours is normal input): the default training is never more than ``TRAINING_SHARE`` of the record,
so at least half of it is monitored; when that shortens the training, or the monitored part
holds fewer than ``MONITORED_WINDOWS`` windows (one after a training the user set), the window
shrinks (never below ``MIN_WINDOW_SAMPLES``; step and inspection period with it, so n_T stays)
so that the training still holds ``MIN_TRAINING_WINDOWS`` windows; and a fitted record is judged window by window
(pooled windows would reach back into the training part). A record the preset fits as it is
(12 h or more for ``siso``, 16 h for ``mimo`` at 5 s; the paper's scenarios) is left alone.

At the paper's 5 s nothing changes (its windows hold 1440 samples). Fields a user sets explicitly
(``{"preset": "siso", "window_s": 14400}``) are kept verbatim: a user value that is not a whole
number of samples stays an error naming the field.
"""
from __future__ import annotations

import json
import math

from ._core import DetectorConfig

__all__ = ["MAX_WINDOW_SAMPLES", "MIN_TRAINING_WINDOWS", "MIN_WINDOW_SAMPLES", "MONITORED_WINDOWS",
           "SINGLE_WINDOW_SIGNIFICANCE", "TIMING_FIELDS", "TRAINING_SHARE", "fit_to_record", "resolve_timing", "span_text"]

# Chosen on the tuning families (docs/detection.md "Presets at other sample times").
MIN_WINDOW_SAMPLES = 600
MAX_WINDOW_SAMPLES = 2700
MIN_TRAINING_WINDOWS = 1.5
# Chosen on short draws of the tuning families (docs/families.md "Short records").
TRAINING_SHARE = 0.5
MONITORED_WINDOWS = 2
SINGLE_WINDOW_SIGNIFICANCE = 0.001  # the level of `mimo` and of `siso` before pooled windows
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


def fit_to_record(config: DetectorConfig, sample_time_s: float, record_s: float, explicit=(),
                  train_end_s: float | None = None) -> tuple[DetectorConfig, str | None]:
    """(config, note): `config` (already resolved at `sample_time_s`) with its training and
    window fitted to a record of `record_s` seconds (module docstring), and a one-line note
    saying what changed, or None. `train_end_s`: the user's end of training (kept as it is, as
    is every field in `explicit`); without it the training is the config's, capped at
    TRAINING_SHARE of the record. A record that still cannot hold training plus one window is
    left for the caller to refuse with the lengths it needs."""
    ts = float(sample_time_s)
    user_training = train_end_s is not None or "train_duration_s" in explicit
    given_training = float(train_end_s) if train_end_s is not None else config.train_duration_s
    training = given_training if user_training else min(given_training, ts * math.floor(TRAINING_SHARE * record_s / ts))
    monitored = 1 if user_training else MONITORED_WINDOWS  # windows the monitored part holds
    fields = {}
    window = config.window_s
    if "window_s" not in explicit:
        fitted = min(window, (record_s - training) / monitored)
        if training < given_training:
            fitted = min(fitted, training / MIN_TRAINING_WINDOWS)
        fitted = ts * max(round(fitted / ts), min(MIN_WINDOW_SAMPLES, round(window / ts)))
        if fitted < window:
            window = fields["window_s"] = fitted
            step = config.step_s
            if "step_s" not in explicit:
                step = fields["step_s"] = ts * max(1, round(fitted / config.window_s * step / ts))
            if "inspection_s" not in explicit:  # the same number of inspected windows (n_T, eq. 23)
                fields["inspection_s"] = max(1, round(config.inspection_s / config.step_s)) * step
    if not user_training:
        training = ts * math.ceil(max(training, MIN_TRAINING_WINDOWS * window) / ts - 1e-9)
        if training != config.train_duration_s:
            fields["train_duration_s"] = training
    if not fields:
        return config, None
    # Pooled windows would reach back into the training part (docs/detection.md "Pooled windows"):
    # a fitted record is judged window by window, at the single-window level.
    if config.pooled_windows > 1 and not {"pooled_windows", "window_significance"} & set(explicit):
        fields.update(pooled_windows=1, window_significance=SINGLE_WINDOW_SIGNIFICANCE)
    out = DetectorConfig.from_json(json.dumps({**json.loads(config.to_json()), **fields}))
    return out, (f"record of {span_text(record_s)}: training {span_text(training)}"
                 f"{'' if user_training else f' (at most {TRAINING_SHARE:.0%} of the record)'}, window "
                 f"{span_text(window)} = {round(window / ts)} samples, step {span_text(out.step_s)}, inspection "
                 f"{span_text(out.inspection_s)}"
                 f"{', single windows (not pooled)' if out.pooled_windows < config.pooled_windows else ''} "
                 f"(fitted so that the record holds the training and {monitored} monitored "
                 f"window{'s' if monitored > 1 else ''})")

