"""Integrating channels: a pole at z = 1 (a level whose OP sets an outflow, an MPC's ramp CV).

`detect` monitors them with the presets `siso` and `mimo` (the residual test: an integrating
channel filtered from rest differs from the true response by a constant once its stable part has
settled, and every window fit carries a level; docs/detection.md "Integrating channels").
`diagnose` fits its candidates to the output error in deviations from an operating point, which
for an integrator turns any offset of the input from its balance (a level loop's OP) into a ramp:
an integrating output's error has each data segment's least-squares line taken out, and every
candidate is fitted beside a ramp and a level per segment (diagnose/whitening.py `output_error`,
`disturbance_drives`); the inputs' Laguerre bases are integrated like the channel
(diagnose/laguerre.py `output_basis`). Step-response errors of an integrating channel compare
rate responses (step_response.py): with an infinite steady-state gain no change of one was ever
material, and a gain x 1.6 on a PI level loop gave "consistent with the data"; with rate
responses alone most records of such a loop got an `output_drift` from their first hour.
`compare` takes each segment's line out of an integrating output's simulation, prediction and
one-step errors the same way.
"""
from __future__ import annotations

import numpy as np

from . import _core


def integrates(g) -> bool:
    """Whether transfer function ``g`` has a pole at z = 1."""
    return len(_core.without_integrators(g).den) < len(g.den)


def integrating_channels(model) -> list[tuple[str, str]]:
    """(output, input) of every channel of ``model`` with a pole at z = 1."""
    return [(o, u) for o in model.outputs for u in model.inputs
            if (g := model.process(o, u)) is not None and integrates(g)]


def integrating_notes(model) -> list[str]:
    """The note compare and diagnose give on each integrating channel of ``model``."""
    return [f"{o} <- {u} integrates (a pole at z = 1): {o}'s errors are taken with each data segment's line "
            "removed (the level it started from and the input's balance are not in the model), so a load that "
            "ramps the output throughout is not seen" for o, u in integrating_channels(model)]


def without_line(v: np.ndarray) -> np.ndarray:
    """``v`` less the least-squares line through its finite samples: what an integrator's error
    owes to an input off its balance and to the level it started from."""
    ok = np.isfinite(v)
    if ok.sum() < 2:
        return v
    t = np.arange(len(v), dtype=float)
    return v - np.polyval(np.polyfit(t[ok], v[ok], 1), t)


def row_integrates(row) -> bool:
    """Whether any channel of an output's ``row`` (None where absent) integrates."""
    return any(g is not None and integrates(g) for g in row)
