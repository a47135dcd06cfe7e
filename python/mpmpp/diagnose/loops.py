"""Single control loops in the model: an input that drives exactly one output, which no other
input drives (OP -> PV of a PI loop, or a single-loop pairing inside a larger model). For
them the data show the controller's action, which a stable loop's process gain must match."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..controller_action import controller_action
from ..signals import Signals, complete_runs
from ..stretches import Stretches


@dataclass(frozen=True)
class Loop:
    output: int                   # index into sig.outputs
    input: int                    # index into sig.inputs
    action: int                   # +1 / -1: the process-gain sign the controller needs; 0 unknown


def single_loops(sig: Signals, data) -> list[Loop]:
    """The model's single loops with the controller action the data show (setpoint column
    ``<output>_sp`` when present, else a constant setpoint)."""
    loops = []
    for i, name in enumerate(sig.outputs):
        drivers = [j for j, g in enumerate(sig.rows[i]) if g is not None]
        if len(drivers) != 1:
            continue
        j = drivers[0]
        if sum(row[j] is not None for row in sig.rows) != 1:
            continue
        sp = data[f"{name}_sp"].to_numpy(dtype=float) if f"{name}_sp" in data.columns else None
        u, y = sig.u[:, j], sig.y[:, i]
        ok = np.isfinite(u) & np.isfinite(y)
        if sp is not None:
            sp = (sp - sig.operating_point[name])[ok]   # deviations, like y
        # the complete rows laid end to end: a new stretch after a missing row or a segment break
        runs = complete_runs(ok, [a for a, _ in sig.segments[1:]])
        starts = Stretches([b - a for a, b in runs]).starts
        loops.append(Loop(i, j, controller_action(u[ok], y[ok], sp, starts)))
    return loops
