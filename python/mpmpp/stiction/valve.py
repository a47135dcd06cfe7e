"""A named valve model applied to an OP record: the model file's actuator block (kind and
parameters in OP units) as a function OP -> valve position.

Kinds and parameters: ``stick_slip`` (S, J; Choudhury, Thornhill & Shah 2005), ``he`` (fs, fd;
He et al. 2007), ``backlash`` (S), ``deadband`` (half_width, centre), ``saturation``
(lower, upper). The simulation itself is the C++ valve (docs/stiction.md).
"""
from __future__ import annotations

import numpy as np

from .._core import Valve, ValveKind

# kind -> (core kind, its two parameters from the block's fields)
VALVE_KINDS = {
    "stick_slip": (ValveKind.stick_slip, lambda p: (p["S"], p["J"])),
    "he": (ValveKind.he, lambda p: (p["fs"], p["fd"])),
    "backlash": (ValveKind.backlash, lambda p: (p["S"], 0.0)),
    "deadband": (ValveKind.deadband, lambda p: (p["half_width"], p["centre"])),
    "saturation": (ValveKind.saturation, lambda p: (p["lower"], p["upper"])),
}
PARAMETERS = {"stick_slip": ("S", "J"), "he": ("fs", "fd"), "backlash": ("S",),
              "deadband": ("half_width", "centre"), "saturation": ("lower", "upper")}


def valve_position(actuator: dict, op) -> np.ndarray:
    """Valve position for the OP record ``op`` (absolute OP units; the valve starts at rest at
    the first sample) under ``actuator`` = {"kind": ..., parameters...}."""
    kind = actuator.get("kind")
    if kind not in VALVE_KINDS:
        raise ValueError(f"actuator kind '{kind}': expected one of {', '.join(VALVE_KINDS)}")
    missing = [p for p in PARAMETERS[kind] if p not in actuator]
    if missing:
        raise ValueError(f"actuator '{kind}': missing parameter {', '.join(missing)}")
    core_kind, params = VALVE_KINDS[kind]
    return Valve(core_kind, *map(float, params(actuator))).apply(np.asarray(op, float))


def actuator_from_fit(kind: str, params: dict) -> dict:
    """The actuator block for a ``fit_valve`` result's hysteresis kind (He's valve is fitted on
    the S, J grid: fs = (S + J) / 2, fd = (S - J) / 2)."""
    if kind == "stick_slip":
        return {"kind": "stick_slip", "S": params["S"], "J": params["J"]}
    if kind == "he":
        return {"kind": "he", "fs": (params["S"] + params["J"]) / 2, "fd": (params["S"] - params["J"]) / 2}
    if kind == "backlash":
        return {"kind": "backlash", "S": params["S"]}
    raise ValueError(f"'{kind}' is not a hysteresis valve kind")
