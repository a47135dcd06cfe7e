"""A small PI-loop simulator for stiction studies: PI controller -> valve -> process -> PV.

The controller reads PV(t) and sets OP(t) in the same sample (velocity-form PI), the valve
(mpmpp's actuator model, at rest at the OP bias before the record) maps OP to position, and
the discrete process responds from the next sample on; the disturbance is added at the PV.
The closed-loop simulator (closed_loop.cpp) draws its disturbances from its own seeded noise
models, whereas stiction studies need given disturbance and valve-noise sequences, so this
loop stays a small Python one.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import Actuator, ActuatorNonlinearity


@dataclass(frozen=True)
class Process:
    """Discrete process B(q)/A(q) q^-delay (delay >= 1 samples), a[0] = 1."""
    b: tuple
    a: tuple
    delay: int = 1

    def __post_init__(self):
        if self.delay < 1:
            raise ValueError("process delay must be >= 1 sample (the PI acts within the sample)")


def simulate_pi_loop(process: Process, kc: float, ti_samples: float, n: int, *,
                     valve: ActuatorNonlinearity | None = None, disturbance=None, setpoint=None,
                     valve_noise=None, op_bias: float = 50.0) -> dict:
    """Closed-loop run of n samples; returns op, pv, sp, position arrays.

    valve: the valve's nonlinearity (default linear); disturbance: additive at the PV
    (length n); valve_noise: added to the valve position (a noisy but linear valve); OP is in %
    around op_bias.
    """
    d = np.zeros(n) if disturbance is None else np.asarray(disturbance, float)
    sp = np.zeros(n) if setpoint is None else np.asarray(setpoint, float)
    w = np.zeros(n) if valve_noise is None else np.asarray(valve_noise, float)
    actuator = Actuator(valve if valve is not None else ActuatorNonlinearity(), op_bias)
    b = np.asarray(process.b, float)
    a = np.asarray(process.a, float)
    nb, na = len(b), len(a) - 1
    x = np.zeros(n)               # process output deviation
    pos = np.zeros(n)             # valve position deviation from the bias
    op = np.zeros(n)
    pv = np.zeros(n)
    e_prev = 0.0
    u = op_bias
    for t in range(n):
        acc = 0.0
        for k in range(nb):
            lag = t - process.delay - k
            if lag >= 0:
                acc += b[k] * pos[lag]
        for k in range(1, na + 1):
            if t - k >= 0:
                acc -= a[k] * x[t - k]
        x[t] = acc
        pv[t] = x[t] + d[t]
        e = sp[t] - pv[t]
        u += kc * (e - e_prev + e / ti_samples)
        e_prev = e
        op[t] = u
        pos[t] = actuator.move(u) - op_bias + w[t]
    return {"op": op, "pv": pv, "sp": sp, "position": pos + op_bias}


def coloured_noise(rng: np.random.Generator, n: int, std: float, pole: float) -> np.ndarray:
    """AR(1) noise 1/(1 - pole q^-1) e scaled to the given standard deviation."""
    e = rng.standard_normal(n + 200)
    x = np.empty_like(e)
    previous = 0.0
    for k, ek in enumerate(e):
        previous = ek + pole * previous
        x[k] = previous
    x = x[200:]  # the first samples carry the zero initial state
    return std * x / np.std(x)
