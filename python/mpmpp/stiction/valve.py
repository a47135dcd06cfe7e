"""A named valve model applied to an OP record: the model file's actuator block (kind and
parameters in OP units) as a function OP -> valve position.

Kinds and parameters: ``stick_slip`` (S, J; Choudhury, Thornhill & Shah 2005), ``he`` (fs, fd;
He et al. 2007), ``backlash`` (S: the play), ``deadband`` (width: the positioner's dead zone),
``saturation`` (lower, upper). The simulation is the C++ actuator (cpp/include/mpmpp/actuator.hpp,
docs/stiction.md), the same the closed-loop simulator drives.
"""
from __future__ import annotations

import numpy as np

from .._core import ActuatorNonlinearity, StictionLaw, actuator_positions

PARAMETERS = {"stick_slip": ("S", "J"), "he": ("fs", "fd"), "backlash": ("S",),
              "deadband": ("width",), "saturation": ("lower", "upper")}


def nonlinearity(actuator: dict) -> ActuatorNonlinearity:
    """The C++ actuator of a model file's block. He's (fs, fd) is the S, J law with
    S = fs + fd and J = fs - fd (He et al. 2007: fs = (S + J) / 2, fd = (S - J) / 2)."""
    kind = actuator.get("kind")
    if kind not in PARAMETERS:
        raise ValueError(f"actuator kind '{kind}': expected one of {', '.join(PARAMETERS)}")
    missing = [p for p in PARAMETERS[kind] if p not in actuator]
    if missing:
        raise ValueError(f"actuator '{kind}': missing parameter {', '.join(missing)}")
    p = {k: float(actuator[k]) for k in PARAMETERS[kind]}
    if kind == "stick_slip":
        return ActuatorNonlinearity(stiction_s=p["S"], stiction_j=p["J"])
    if kind == "he":
        return ActuatorNonlinearity(stiction_law=StictionLaw.he, stiction_s=p["fs"] + p["fd"],
                                    stiction_j=p["fs"] - p["fd"])
    if kind == "backlash":
        return ActuatorNonlinearity(backlash=p["S"])
    if kind == "deadband":
        return ActuatorNonlinearity(deadband=p["width"])
    return ActuatorNonlinearity(min=p["lower"], max=p["upper"])


def valve_position(actuator: dict, op) -> np.ndarray:
    """Valve position for the OP record ``op`` (absolute OP units; the valve starts at rest at
    the first sample) under ``actuator`` = {"kind": ..., parameters...}."""
    op = np.asarray(op, float)
    return np.asarray(actuator_positions(op, nonlinearity(actuator), float(op[0])))


def actuator_from_fit(kind: str, params: dict) -> dict:
    """The actuator block for a ``fit_valve`` result's hysteresis kind (He's valve is fitted on
    the S, J grid: fs = (S + J) / 2, fd = (S - J) / 2)."""
    if kind == "stick_slip":
        return {"kind": "stick_slip", "S": params["S"], "J": params["J"]}
    if kind == "he":
        return {"kind": "he", "fs": (params["S"] + params["J"]) / 2, "fd": (params["S"] - params["J"]) / 2}
    if kind == "backlash":
        return {"kind": "backlash", "S": params["S"]}
    if kind == "deadband":
        return {"kind": "deadband", "width": params["width"]}
    raise ValueError(f"'{kind}' is not a hysteresis valve kind")
