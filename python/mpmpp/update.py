"""Apply diagnosed findings to the model: ``mpmpp update MODEL DATA --apply F1[,F2]``.

The diagnosis is re-run (it is deterministic), the named findings' model changes are applied
and the new model is returned (and written through ``mpmpp.save_model``, atomically).

How each effect lands in docs/formats.md's fixed model format:
- gain / time_constant / delay: the channel is replaced by the fitted channel;
- missing_coupling: a new channel output <- input;
- unmodeled_input: the data column becomes a new model input with a fitted channel;
- noise_change: the output's noise model becomes H / A(q), A the AR correction fitted after
  the onset (roots reflected inside the unit circle if needed, so H stays stable);
- output_drift: the noise model gets a slow pole, H / (1 - rho q^-1): a drift is a
  disturbance the file can only describe stochastically (no deterministic-trend field);
- input_nonlinearity of a single loop: the valve goes into the model file's ``actuators``
  block, the loop's channel and noise model become the ones fitted from the valve position;
  of an input driving several outputs: the channels get the describing-function gain (the
  linear scale that best reproduces the backlash response).

An applied finding that changes what a controller given the new model would do beyond a
re-tuning (a channel whose gain falls below a quarter of the model's, or reverses its sign) gets
a caution: the model then says the input hardly acts, and a controller would move it several
times as hard; that is more often a valve stuck or at a limit of its travel than a process
change, and a reversed sign from routine closed-loop data deserves a step test first.

Every refit uses the even held-out blocks (1 h, shorter in a short record) after the
finding's onset only; the error before and after is reported on the odd blocks, which the
refit never saw.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .diagnose import DiagnoseResult, ModelChange, diagnose, one_step_errors
from .diagnose.changes import apply_changes
from .diagnose.pipeline import BLOCK_S, SEGMENT_S, diagnosis_signals, record_lengths
from .diagnose.process import DEAD_CHANNEL, SCALED_CHANNEL_EFFECTS, ratio_text
from .diagnose.process_error import process_errors
from .diagnose.result import PROCESS_METRIC


@dataclass
class OutputError:
    output: str
    onset_s: float
    error_before: float
    error_after: float
    process_error_before: float = float("nan")   # diagnose/process_error.py
    process_error_after: float = float("nan")


@dataclass
class UpdateResult:
    applied: list[str]
    errors: list[OutputError]
    model: object = field(repr=False)           # the new mpmpp.Model
    diagnosis: DiagnoseResult = field(repr=False, default=None)
    cautions: list[str] = field(default_factory=list)   # controller_cautions
    metric: str = ("RMS of the one-step prediction error (deviation units) on held-out blocks "
                   "after each finding's onset, not used for the refit")
    process_metric: str = PROCESS_METRIC

    def to_dict(self) -> dict:
        doc = {"applied": self.applied, "metric": self.metric, "process_metric": self.process_metric,
               "errors": [{"output": e.output, "onset_s": e.onset_s,
                           "error_before": _f(e.error_before), "error_after": _f(e.error_after),
                           "process_error_before": _f(e.process_error_before),
                           "process_error_after": _f(e.process_error_after)}
                          for e in self.errors],
               "cautions": list(self.cautions)}
        if self.diagnosis is not None and self.diagnosis.notes:
            doc["notes"] = list(self.diagnosis.notes)  # how the data were read, as diagnose says
        return doc

    def summary(self) -> str:
        lines = [f"update: applied {', '.join(self.applied)}"]
        for e in self.errors:
            change = 100.0 * (e.error_after / e.error_before - 1.0) if e.error_before else float("nan")
            fall = (100.0 * (e.process_error_after / e.process_error_before - 1.0)
                    if e.process_error_before else float("nan"))
            lines.append(f"  {e.output}: error {e.error_before:.4g} -> {e.error_after:.4g} ({change:+.1f} %), "
                         f"process part {e.process_error_before:.4g} -> {e.process_error_after:.4g} "
                         f"({fall:+.1f} %) after t={e.onset_s / 3600:.1f} h")
        lines += [f"  caution: {c}" for c in self.cautions]
        lines.append(f"  error = {self.metric}")
        lines.append(f"  {self.process_metric}")
        if self.diagnosis is not None:
            lines += [f"  note: {n}" for n in self.diagnosis.notes]
        return "\n".join(lines)

    def save(self, path) -> None:
        from .io import save_model

        save_model(self.model, path)

    def plot(self, out_dir) -> list[Path]:
        return self.diagnosis.plot(out_dir) if self.diagnosis is not None else []


def update(model, data, apply, train_end_s: float | None = None, name: str | None = None,
           min_segment_s: float = SEGMENT_S, block_s: float = BLOCK_S,
           actuator_search: bool | None = None) -> UpdateResult:
    """Re-diagnose, apply the findings named in ``apply`` (ids like "F1"), return the new model.
    ``min_segment_s`` / ``block_s`` / ``actuator_search`` as for ``diagnose`` (the same
    findings are re-derived)."""
    ids = [a.strip() for a in (apply.split(",") if isinstance(apply, str) else apply) if a.strip()]
    if not ids:
        raise ValueError("--apply: give at least one finding id (e.g. F1)")
    diagnosis = diagnose(model, data, train_end_s=train_end_s, min_segment_s=min_segment_s, block_s=block_s,
                         actuator_search=actuator_search)
    findings = [diagnosis.finding(i) for i in ids]
    changes: list[ModelChange] = []
    for f in findings:
        changes += f.model_changes()
    new_model = apply_changes(model, changes, name)

    sig = diagnosis_signals(model, data, train_end_s).sig
    time_s = sig.time_s
    block = record_lengths(len(time_s), sig.sample_time_s, min_segment_s, block_s).block
    heldout = (np.arange(len(time_s)) // block) % 2 == 1
    errors = []
    for out_name in dict.fromkeys(c.output for c in changes):
        i = sig.outputs.index(out_name)
        # a finding may change several outputs (an actuator drives each output of its input)
        onset_s = min(f.onset_s for f in findings if any(c.output == out_name for c in f.model_changes()))
        rows = heldout & (time_s >= onset_s)
        before = one_step_errors(sig, i, [])
        after = one_step_errors(sig, i, changes)
        ok = rows & np.isfinite(before) & np.isfinite(after)
        ok[: 60] = False
        process_before, process_after = process_errors(sig, i, changes, sig.seconds_to_index(onset_s), block)
        errors.append(OutputError(out_name, onset_s, _rms(before[ok]), _rms(after[ok]), process_before, process_after))
    return UpdateResult(applied=ids, errors=errors, model=new_model, diagnosis=diagnosis,
                        cautions=controller_cautions(findings))


def controller_cautions(findings) -> list[str]:
    """One line per applied channel finding that a controller given the new model would act on
    differently than a re-tuning does: a gain cut below DEAD_CHANNEL of the model's, or a sign
    reversed."""
    cautions = []
    for f in findings:
        ratio = f.estimate.get("gain_ratio") if f.effect in SCALED_CHANNEL_EFFECTS else None
        if ratio is None:
            continue
        channel = f"{f.output} <- {f.input}"
        if ratio < 0.0:
            cautions.append(f"{f.id} reverses the sign of {channel} ({ratio_text(ratio)}x the model's gain): a "
                            f"controller given this model moves {f.input} the other way, which drives {f.output} "
                            "away from its setpoint if the finding is wrong; confirm the sign with a step test "
                            "before the model goes into a controller")
        elif ratio < DEAD_CHANNEL:
            harder = f"about {1.0 / ratio:.0f} times as hard" if ratio > 0.0 else "without bound"
            cautions.append(f"{f.id} cuts the gain of {channel} to {ratio_text(ratio)}x: a controller given this model "
                            f"moves {f.input} {harder} for the same correction of {f.output}; an input that has all "
                            "but stopped acting is more often a valve stuck or at a limit of its travel than a "
                            "process change: check the valve before the model goes into a controller")
    return cautions


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2))) if len(x) else float("nan")


def _f(x: float):
    return round(x, 6) if math.isfinite(x) else None
