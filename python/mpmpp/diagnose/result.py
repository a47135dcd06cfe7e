"""What ``diagnose`` returns: findings, the model changes they propose, the ranked result."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._core import TransferFunction

EFFECTS = ("gain", "time_constant", "delay", "missing_coupling", "unmodeled_input",
           "noise_change", "output_drift", "input_nonlinearity")
LINEAR_CHANNEL_EFFECTS = ("gain", "time_constant", "delay", "missing_coupling", "unmodeled_input")
PROCESS_EFFECTS = LINEAR_CHANNEL_EFFECTS + ("input_nonlinearity",)
DISTURBANCE_EFFECTS = ("noise_change", "output_drift")   # "the process model still fits"

METRIC = ("RMS of the one-step prediction error of the output (deviation units) on "
          "held-out blocks after onset_s")
PROCESS_METRIC = ("process part = RMS of the input-explained part of y - G u (the simulation error "
                  "of the output's process part; a whitened Laguerre-basis filter of the inputs "
                  "fitted on the even held-out blocks after onset_s, RMS on the odd ones)")


class InsufficientData(Exception):
    """A candidate cannot be assessed on these data (too few held-out rows after its onset);
    the diagnosis reports it as a note, not as an error in the input."""


@dataclass
class ModelChange:
    """What ``update`` applies: a process channel (possibly from a new input column) set to
    ``channel``, the output's noise model set to ``noise``, and/or the input's valve model set
    to ``actuator`` (the model file's actuator block: the channel is then driven by the valve
    position instead of the OP)."""

    output: str
    input: str | None = None
    channel: TransferFunction | None = None
    noise: TransferFunction | None = None
    new_input: bool = False
    actuator: dict | None = None


@dataclass
class HeldOutError:
    """RMS one-step error of one output on the held-out blocks after an onset: with the nominal
    model and with the model ``update`` writes (fitted on the other blocks)."""

    before: float
    after: float

    @property
    def improved(self) -> bool:
        return self.after < self.before


@dataclass
class Finding:
    id: str
    effect: str
    output: str | None
    input: str | None
    onset_s: float
    confidence: float
    estimate: dict
    error_before: float
    error_after: float
    explanation: str
    score: float = field(repr=False, default=0.0)
    change: ModelChange | None = field(repr=False, default=None)
    # the simulation error of the output's process part, nominal model and updated model
    # (diagnose/process_error.py); NaN when the blocks after the onset are too short
    process_error_before: float = float("nan")
    process_error_after: float = float("nan")
    # the chi-square CDF of the held-out gain; ``confidence`` is the calibrated probability
    # that the finding is right (diagnose/confidence.py)
    evidence_confidence: float = field(repr=False, default=float("nan"))
    # ``confidence`` is already a probability calibrated on the population the finding belongs
    # to (the valve fit's, on single PI loops with and without stiction): the scenario-family
    # map (diagnose/confidence.py) leaves it as it is.
    calibrated: bool = field(repr=False, default=False)
    # the actuator search's score on ``input`` (its best candidate, penalised, passed or not);
    # None when the search did not run there. A gain that an actuator nonlinearity explains
    # nearly as well is a less confident gain (diagnose/confidence.py).
    actuator_score: float | None = field(repr=False, default=None)
    # An actuator drives several outputs: the channel changes of the outputs other than
    # ``output`` (the one the finding is reported on), and every output it drives.
    extra_changes: list[ModelChange] = field(repr=False, default_factory=list)
    outputs_driven: tuple[str, ...] = field(repr=False, default=())
    # A channel change's onset set (process.py): the first and last onsets whose fit is within
    # the chi-square 95 % point of the best; None where the search gives no such set.
    onset_earliest_s: float | None = None
    onset_latest_s: float | None = None
    # a gain fitted with a step of the output's level at its onset (shapes.Shape.level_step),
    # which no model update carries
    level_step: bool = field(repr=False, default=False)

    def model_changes(self) -> list[ModelChange]:
        """Every change ``update`` applies for this finding."""
        return ([self.change] if self.change is not None else []) + self.extra_changes

    def to_dict(self) -> dict:
        d = {"id": self.id, "effect": self.effect}
        if self.output is not None:
            d["output"] = self.output
        if self.input is not None:
            d["input"] = self.input
        d.update(onset_s=round(self.onset_s, 3), confidence=round(self.confidence, 4),
                 estimate={k: rounded(v) for k, v in self.estimate.items()},
                 error_before=rounded(self.error_before), error_after=rounded(self.error_after),
                 process_error_before=rounded(self.process_error_before),
                 process_error_after=rounded(self.process_error_after),
                 explanation=self.explanation)
        if self.onset_earliest_s is not None:
            d.update(onset_earliest_s=round(self.onset_earliest_s, 3), onset_latest_s=round(self.onset_latest_s, 3))
        return d


@dataclass
class DiagnoseResult:
    model: str
    train_end_s: float | None
    findings: list[Finding]
    metric: str = METRIC
    process_metric: str = PROCESS_METRIC
    # per output: time and the nominal model's one-step error; per finding id: the one-step
    # error of its output with the model ``update`` writes (for the figures)
    time_s: np.ndarray = field(repr=False, default=None)
    residuals: dict = field(repr=False, default_factory=dict)
    residuals_after: dict = field(repr=False, default_factory=dict)
    # per finding id: the output's process part (input-explained part of y - G u) with the
    # nominal model and with the updated one (diagnose/process_error.py)
    process_parts: dict = field(repr=False, default_factory=dict)
    # what the user should know about how the data were read (estimated noise models, parts
    # of the search the data were too short for)
    notes: list[str] = field(default_factory=list)

    @property
    def start_s(self) -> float:
        """The first row diagnosed (the record's, or the first at or after ``train_end_s``): a
        finding with this onset is present from the start, the model's own error."""
        first = 0 if self.train_end_s is None else int(np.searchsorted(self.time_s, self.train_end_s))
        return float(self.time_s[first])

    def to_dict(self) -> dict:
        d = {"findings": [f.to_dict() for f in self.findings]}
        if self.notes:
            d["notes"] = list(self.notes)
        return d

    def finding(self, finding_id: str) -> Finding:
        for f in self.findings:
            if f.id == finding_id:
                return f
        known = ", ".join(f.id for f in self.findings) or "none"
        raise ValueError(f"--apply: no finding '{finding_id}' (findings: {known})")

    def summary(self) -> str:
        notes = [f"  note: {n}" for n in self.notes]
        if not self.findings:
            return "\n".join([f"diagnose: model '{self.model}' is consistent with the data (no finding)", *notes])
        lines = [f"diagnose: model '{self.model}', {len(self.findings)} finding(s), most likely first"]
        for f in self.findings:
            lines.append(f"  {f.id} [{f.effect}] {f.explanation} (confidence {f.confidence:.2f}; "
                         f"error {f.error_before:.4g} -> {f.error_after:.4g}; "
                         f"process part {f.process_error_before:.4g} -> {f.process_error_after:.4g})")
        lines.append(f"  error = {self.metric}")
        lines.append(f"  {self.process_metric}")
        return "\n".join(lines + notes)

    def plot(self, out_dir, origin=None) -> list[Path]:
        """One figure per output; ``origin``: the data's calendar origin (time axes in its own time)."""
        from .plots import plot_residuals

        return plot_residuals(self, out_dir, origin)


def rounded(v):
    """JSON-ready value: floats to 6 decimals, non-finite to null."""
    if isinstance(v, float):
        return round(v, 6) if math.isfinite(v) else None
    if isinstance(v, list):
        return [rounded(x) for x in v]
    return v
