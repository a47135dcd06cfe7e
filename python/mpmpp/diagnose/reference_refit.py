"""The reference a later change is judged against when the model was wrong from the start.

A hand-written model is off in gain, time constant and dead time at once; a standing finding
corrects one of them. Against that partial correction the rest of the error still shows, and
wherever the disturbance or the excitation changes it is fitted as a change of its own: on the
tuning family pi_siso_rough (seeds 0-7 and 10-17), four of the sixteen noise-change controls
came out with a dynamics change dated at the noise change (confidence 0.95-0.98), two of them
from the second pass. So a change that the second pass finds must hold against the standing finding's
channel refitted in full (``identify``'s closed-loop ARX-OE with its dead-time search, in the
model channel's class: self-regulating or integrating) on the rows before that change: the model as it was before it, which is what a later change is a change
from. Refitted on the whole record instead, the reference averages a real change in and hides
it (pi_siso_rough seeds 0-15: three of forty changes lost).
"""
from __future__ import annotations

from ..integrating import integrates
from ..model_identification import DEFAULT_MAX_DEAD_TIME_S, NotIdentified, model_from_data
from ..process_class import CLASSES_BY_NAME
from ..step_response import settling_samples
from ..timeaxis import seconds_of
from .result import Finding, ModelChange

# The refit uses at most the last this many rows before the change: identification costs up to
# about 1 ms CPU per row at 5 s (121 dead times searched) and grows with the dead times searched
# (_longest_dead_time_s); the tests' refit on 6,480 rows has the plant's gain within 8 %.
MAX_ROWS = 10_000


def refitted_before(model, data, standing: list[Finding], end_s: float) -> list[ModelChange] | None:
    """The standing findings' channels identified on the last MAX_ROWS rows of ``data`` before
    ``end_s`` (on the data's time axis, as a finding's onset_s), or None when that reference
    cannot be had: an output with more than one modelled input (a MISO refit would replace
    channels no finding questioned), too few rows, or data that do not identify the channel."""
    rows = int((seconds_of(data) < end_s).sum())
    before = data.iloc[max(rows - MAX_ROWS, 0):rows]
    changes = []
    for f in standing:
        if f.input is None or f.input not in model.inputs:
            return None
        if [j for j in model.inputs if model.process(f.output, j) is not None] != [f.input]:
            return None
        nominal = model.process(f.output, f.input)
        integrating = integrates(nominal)
        longest = _longest_dead_time_s(model, nominal, integrating)
        try:
            ident = model_from_data(before, [f.input], [f.output], workers=1, max_dead_time_s=longest,
                                    classes=CLASSES_BY_NAME["integrating" if integrating else "self-regulating"])
        except (NotIdentified, ValueError):
            return None
        g = ident.model.process(f.output, f.input)
        if g is None:
            return None
        changes.append(ModelChange(output=f.output, input=f.input, channel=g))
    return changes


def _longest_dead_time_s(model, nominal, integrating: bool) -> float:
    """The refit's dead times end at the model channel's settling time (its dead time plus five
    time constants plus ten samples, ``settling_samples``), at most identify's default: a dead
    time beyond it is no standing error of this channel (`diagnose`'s own dead-time search ends
    14 samples after the model's), and at 1 s the default's 601 dead times made the refit 43 s
    of the 52 s `diagnose` took on held-out pi_siso_handwritten seed 707 (20 h at 1 s; settling
    73 samples). An integrating channel settles never: the default."""
    if integrating:
        return DEFAULT_MAX_DEAD_TIME_S
    return min(DEFAULT_MAX_DEAD_TIME_S, settling_samples(nominal) * model.sample_time_s)
