"""``diagnose(model, data)``: whiten each output, search process and actuator candidates, then
the disturbance side where the process passed, and rank what survives."""
from __future__ import annotations

import math

from ..signals import extract
from .actuator import actuator_findings
from .noise import noise_finding
from .process import process_findings
from .result import DiagnoseResult, Finding
from .whitening import AR_ORDER, output_residual


def diagnose(model, data, train_end_s: float | None = None, min_segment_s: float = 3600.0,
             block_s: float = 3600.0, min_effect: float = 0.01) -> DiagnoseResult:
    """Ranked findings (FORMATS.md ``diagnose --json``) for ``model`` against ``data``.

    ``min_effect``: practical significance; a finding must remove at least this fraction of the
    (whitened) one-step error variance after its onset on held-out data. Closed-loop records are
    long, so statistically significant but practically void mismatches (a model one sample off
    in dead time, a gain 3 % off) would otherwise be reported.

    ``train_end_s``: the data before it are taken to agree with the model (operating point
    from them, no onset inside them except a change present from the start).
    """
    if train_end_s is not None and train_end_s < 0:
        raise ValueError(f"--train-end must be >= 0 seconds, got {train_end_s}")
    time_s = data["time"].to_numpy(dtype=float)
    reference = None if train_end_s is None else time_s < train_end_s
    if reference is not None and reference.sum() < 10:
        raise ValueError(f"--train-end {train_end_s} leaves fewer than 10 rows of training data")
    sig = extract(model, data, reference=reference)
    ts = sig.sample_time_s
    min_segment = max(int(round(min_segment_s / ts)), 4 * AR_ORDER)
    block = max(int(round(block_s / ts)), 10)
    step = max(min_segment // 60, 1)
    first_onset = 0 if train_end_s is None else sig.seconds_to_index(train_end_s)
    n = len(time_s)
    if n < 3 * min_segment:
        raise ValueError(f"data: {n} rows are too few for diagnosis (need at least {3 * min_segment})")
    logn = math.log(n)

    outputs = [output_residual(sig, i, min_segment, first_onset, block) for i in range(len(sig.outputs))]
    found: list[Finding] = []
    for out in outputs:
        found += process_findings(out, first_onset, min_segment, step, logn, min_effect)
    # An actuator nonlinearity also looks like gain/dynamics changes of that input's channels:
    # it replaces them when it explains more than they do together.
    for nl in actuator_findings(outputs, sig, first_onset, min_segment, step, logn, min_effect):
        rivals = [f for f in found if f.output in nl.outputs_driven and (
            (f.input == nl.input and f.effect in ("gain", "time_constant", "delay")) or f.effect == "output_drift")]
        if nl.score > sum(f.score for f in rivals):
            found = [f for f in found if all(f is not r for r in rivals)] + [nl]
    with_process = {f.output for f in found} | {o for f in found for o in f.outputs_driven}
    for out in outputs:
        if out.name not in with_process:
            f = noise_finding(out, first_onset, logn)
            if f is not None:
                found.append(f)
    found.sort(key=lambda f: -f.score)
    for k, f in enumerate(found, start=1):
        f.id = f"F{k}"
    return DiagnoseResult(model=str(model.name), train_end_s=train_end_s, findings=found,
                          time_s=time_s, residuals={o.name: o.e for o in outputs})
