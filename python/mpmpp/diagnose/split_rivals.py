"""After a significant disturbance split (whitening.py) an output's change after the onset has two
rival explanations: a process change, whose effect the split's new AR correction partly takes
in, and a new disturbance colour. They are weighed here on the held-out blocks, both ways: a
disturbance verdict the process candidates outscore, and channel findings a noise change dwarfs."""
from __future__ import annotations

import numpy as np

from .errors import one_step_errors
from .noise import DisturbanceVerdict, noise_finding
from .process import process_findings
from .result import LINEAR_CHANNEL_EFFECTS, Finding, InsufficientData
from .whitening import disturbance_split, split_is_significant, without_split

# A noise change this many times the score of the dated findings of channels from the inputs on
# its output, which leave its split significant, takes their place (``changes_dwarfed_by_the_split``).
# Chosen on the tuning families, seeds 0-7: at 10, 5 of the 10 controls with a false process
# finding lost it (4 once gains with a level step were left out) and 1 right finding was at
# risk (a gain of 502 beside a noise change of 8,904, which returns when scored without the
# split); at 5, 6 and 4 (docs/diagnose.md "Channel findings a noise change dwarfs").
NOISE_CHANGE_DWARFS = 10.0
# The channels from the inputs, which the controllers move in answer to the disturbance. Not an
# unmodelled measured variable: held-out mpc_siso_fast seed 698, an extra column entering y1
# with 127,976 chi-square units of evidence, scored 785 beside the split's 45,014 and was lost
# to a noise change when the rule took every linear channel.
FEEDBACK_CHANNEL_EFFECTS = tuple(e for e in LINEAR_CHANNEL_EFFECTS if e != "unmodeled_input")


def changes_the_split_absorbed(out, verdict, *search) -> list[Finding]:
    """The process findings that replace a disturbance verdict on output ``out`` (``search``:
    the arguments of ``process_findings`` after the residual), or none.

    The disturbance split found where the one-step error changed, and each side's AR correction
    absorbed what a process change made predictable. So when the split is significant, the
    candidates are scored again with the disturbance unchanged (one correction throughout,
    ``without_split``) and replace the verdict when the inputs explain the change (the input
    filter's test) or, for a ``noise_change``, when the best of them scores higher than it: both
    scores are a held-out log-likelihood gain less a charge per fitted parameter, so the
    explanation the held-out blocks favour wins. Without external excitation a small dead-time
    change and a new disturbance colour are close to each other after the onset (the input is a
    filter of past errors, docs/diagnose.md "Disturbance or process"), and the split's new AR
    takes the dead time in. Tuning families, seeds 0-19, the 177 runs with a dated
    ``noise_change`` (160 controls): dead-time changes named 3 -> 6 of 17 change runs, controls
    with a process finding 0 -> 0; the controls' best candidates reach at most 0.71 of the noise
    change's score, the changes gained 2.1-6.7 times it. Taking the candidates whatever the scores
    (as tried on 2026-11-29), 35 of the 160 controls got a process finding. A noise change
    that outscores them still loses when their changes, applied from their onsets, leave no
    significant split (``_split_remains``): tuning families seeds 0-7 (984 runs), 2 changes
    more named (a dead time and a gain read as noise changes), the 18 noise-change controls
    that reached this test all kept (their split statistic with the candidate applied 194-3732,
    the threshold 60-70)."""
    if not out.split_significant:
        return []
    absorbed = verdict.finding is not None and verdict.finding.effect == "noise_change"
    if not (verdict.input_driven or absorbed):
        return []
    redo = process_findings(without_split(out), *search)
    if (redo and not verdict.input_driven and max(f.score for f in redo) <= verdict.finding.score
            and _split_remains(out, redo, *search[:2])):
        return []
    return redo


def changes_dwarfed_by_the_split(out, found: list[Finding], first_onset: int, min_segment: int, logn: float,
                                  min_effect: float) -> tuple[list[Finding], str | None, DisturbanceVerdict | None]:
    """The converse of ``changes_the_split_absorbed``: output ``out``'s findings, when they are
    dated changes of channels from the inputs (FEEDBACK_CHANNEL_EFFECTS) beside a significant
    disturbance split, and the note that withholds them when the split's ``noise_change``
    scores NOISE_CHANGE_DWARFS times the best of them and stays significant with them applied
    (``_split_remains``), with that verdict (for the disturbance step, not computed twice); else
    no findings, no note and no verdict. The candidates are fitted beside the split's own
    corrections, so a channel change scored there is what is left after a new disturbance
    colour; in closed loop the controller's answer to that colour still leaves a few tens of
    chi-square units for a gain or dead time dated near it (tuning
    seeds 0-7: 7 of the 10 controls with a false process finding, noise changes of 57-8,117
    against findings of 1-50). Withheld, the output goes to the disturbance verdict, where
    ``changes_the_split_absorbed`` weighs the process candidates again without the split.
    Actuator findings are left alone: a valve makes the linear whitening's colour change by
    itself, and its linear equivalent never accounts for the split. So is a gain fitted with a
    step of the output's level at its onset: the split sees that step, and no model change
    carries it (a gain x2 about another operating point on the test loop, 8000 rows, was lost
    to a noise change: tests/python/test_diagnose_sizes.py)."""
    mine = [f for f in found if f.output == out.name]
    if (not out.split_significant or not mine or any(out.name in f.outputs_driven for f in found)
            or not all(f.effect in FEEDBACK_CHANNEL_EFFECTS and not f.level_step
                       and out.sig.seconds_to_index(f.onset_s) > first_onset for f in mine)):
        return [], None, None
    try:
        verdict = noise_finding(out, first_onset, logn, min_effect)
    except InsufficientData:
        return [], None, None
    noise = verdict.finding
    best = max(f.score for f in mine)
    if (noise is None or noise.effect != "noise_change" or not noise.score >= NOISE_CHANGE_DWARFS * best
            or not _split_remains(out, mine, first_onset, min_segment)):
        return [], None, None
    named = ", ".join(f"{f.effect} of {f.input} -> {f.output} (score {f.score:.0f})" for f in mine)
    return mine, (f"{named} withheld: the disturbance on {out.name} changed at "
                  f"t={out.sig.time_s[out.split_onset] / 3600:.1f} h (noise change score {noise.score:.0f}, "
                  f"{noise.score / max(best, 1e-9):.0f}x the finding's) and the finding does not account for "
                  f"it; a channel change this small beside a new disturbance colour is not told from the "
                  f"controller's answer to that colour"), verdict


def _split_remains(out, redo: list[Finding], first_onset: int, min_segment: int) -> bool:
    """Whether the disturbance split is still significant in the one-step error with the process
    changes ``redo`` applied from their onsets. When it is not, those changes explain everything
    the split's new colour did, with a few parameters instead of an AR correction's: the nested
    comparison, where the two scores are not on one baseline (the noise change's gain is counted
    against the nominal noise model, the process change's against the correction refitted
    throughout)."""
    t = np.arange(len(out.e))
    e, changes = out.e, []
    for f in sorted(redo, key=lambda f: f.onset_s):    # each change from its onset on
        changes += f.model_changes()
        e = np.where(t >= out.sig.seconds_to_index(f.onset_s), one_step_errors(out.sig, out.i, changes), e)
    e = np.nan_to_num(e)
    split = disturbance_split(e, out.weight, out.noise.inverse(), first_onset, min_segment)
    return split_is_significant(split, len(e))
