"""After a significant disturbance split (whitening.py) an output's change after the onset has two
rival explanations: a process change, whose effect the split's new AR correction partly takes
in, and a new disturbance colour. They are weighed here on the held-out blocks."""
from __future__ import annotations

import numpy as np

from .errors import one_step_errors
from .process import process_findings
from .result import Finding
from .whitening import disturbance_split, split_is_significant, without_split


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
