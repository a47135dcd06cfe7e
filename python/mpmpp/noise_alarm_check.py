"""A second look at a noise alarm that no MPM alarm on the same output explains.

In closed loop without external excitation the controller makes the inputs a filtered copy of
the disturbance, so a channel change also changes the colour of the output error: the noise
test sees it, while the process test, whose power is set by the uncertainty of its training
reference, may stay below its level. The change is then seen only as a noise alarm
(docs/families.md "Detection by the record's evidence": 12 of the 27 process changes the tuning
families' records show by more than 100 chi-square units and the presets missed, seeds 340-359).

``diagnose`` looks at the whole record at once: it searches the change's onset, fits the
disturbance beside each candidate and scores candidates on held-out blocks, and on those runs it
named the changed channel in 10 of the 12. So for every output with a noise alarm and no MPM
alarm on any of its channels, the check runs ``diagnose`` on the same record and reports its top
process finding on that output (or that it sees none). It changes no alarm: an MPM alarm keeps
the detector's own false-alarm rate, the check is advice with the finding's calibrated
confidence beside it.
"""
from __future__ import annotations

from dataclasses import dataclass

from .diagnose import PROCESS_EFFECTS, diagnose


@dataclass
class NoiseAlarmCheck:
    output: str
    start_s: float                  # the output's first noise alarm, on the result's time axis
    finding: dict | None            # diagnose's top process finding on the output (to_dict), or None
    refused: str | None = None      # why diagnose could not look at the record

    def to_dict(self) -> dict:
        d = {"output": self.output, "start_s": self.start_s, "finding": self.finding}
        return d if self.refused is None else {**d, "refused": self.refused}

    def note(self, stamp) -> str:
        head = (f"{self.output}: noise alarm from {stamp(self.start_s)} with no MPM alarm on its channels; "
                f"diagnose on the whole record")
        if self.refused is not None:
            return head + f" could not check it ({self.refused})"
        if self.finding is None:
            return head + " finds no process change either (a disturbance change)"
        return (head + f" finds: {self.finding['explanation']} (confidence {self.finding['confidence']:.2f}); "
                "in closed loop a process change can read as a disturbance change; "
                "see `mpmpp diagnose` before re-identifying the noise model")


def unexplained_noise_alarms(result) -> dict:
    """{output: first noise alarm start} for outputs whose noise channel alarmed while none of
    their process channels did, anywhere in the record."""
    mpm = {a["output"] for a in result.alarms if a["kind"] == "process"}
    first: dict = {}
    for a in result.alarms:
        if a["kind"] == "noise" and a["output"] not in mpm:
            first.setdefault(a["output"], float(a["start_s"]))
    return first


def check_noise_alarms(model, data, result) -> list[NoiseAlarmCheck]:
    """The check of every unexplained noise alarm of ``result`` (detect on ``model`` and
    ``data``); diagnose runs once, and only when there is one."""
    pending = unexplained_noise_alarms(result)
    if not pending:
        return []
    try:
        findings = [f for f in diagnose(model, data).findings if f.effect in PROCESS_EFFECTS]
    except ValueError as exc:  # a record detect monitors but diagnose refuses (too short)
        return [NoiseAlarmCheck(output, start, None, str(exc)) for output, start in pending.items()]
    checks = []
    for output, start in pending.items():
        top = next((f for f in findings if f.output == output), None)
        checks.append(NoiseAlarmCheck(output, start, None if top is None else top.to_dict()))
    return checks
