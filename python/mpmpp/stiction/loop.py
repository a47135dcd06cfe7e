"""A PI loop for stiction studies: PI controller -> valve -> process -> PV, run by the C++
closed-loop simulator (closed_loop.cpp with one PID loop, pid_controller.cpp, and the actuator
model, actuator.cpp).

The controller reads PV(t) and sets OP(t) in the same sample (velocity-form PI), the valve maps
OP to position, and the discrete process responds from the next sample on; the disturbance is
added at the PV. Before the record the loop is at rest: PV = SP = 0, OP and valve at the bias,
and the disturbance starts with the record (simulated as one lead-in sample that is dropped).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import (
    ActuatorNonlinearity,
    ClosedLoopConfig,
    Event,
    EventKind,
    Model,
    PidLoop,
    Plant,
    TransferFunction,
    simulate_closed_loop,
)


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
                     valve_noise=None, op_bias: float = 50.0,
                     op_limits: tuple[float, float] = (-np.inf, np.inf)) -> dict:
    """Closed-loop run of n samples; returns op, pv, sp, position arrays.

    valve: the valve's nonlinearity (default linear); disturbance: additive at the PV
    (length n); valve_noise: added to the valve position (a noisy but linear valve); OP is in %
    around op_bias; op_limits: the controller output's range (the velocity-form PI stops at a
    limit and leaves it as soon as the error reverses: no windup).
    """
    def lead_in(x):  # one sample at rest before the record
        return np.r_[0.0, np.asarray(x, float)].reshape(n + 1, 1)

    g = TransferFunction(np.asarray(process.b, float), np.asarray(process.a, float),
                         process.delay)
    cfg = ClosedLoopConfig()
    cfg.model = Model("pi_loop", 1.0, ["OP"], ["PV"], {"PV": {"OP": g}})
    plant = Plant()
    plant.process = [[g]]
    plant.noise = [TransferFunction()]
    plant.sigma = np.zeros(1)
    plant.actuators = [valve if valve is not None else ActuatorNonlinearity()]
    cfg.plant = plant
    loop = PidLoop()
    loop.gain, loop.integral_time_s = kc, ti_samples   # sample time 1
    loop.min, loop.max = op_limits
    cfg.pid_loops = [loop]
    cfg.u_operating = np.array([op_bias])
    cfg.y_operating = np.zeros(1)
    cfg.num_samples = n + 1
    sp = np.zeros(n) if setpoint is None else np.asarray(setpoint, float)
    events = []
    for t in np.flatnonzero(np.diff(np.r_[0.0, sp]) != 0):
        ev = Event()
        ev.sample, ev.kind, ev.output, ev.value = int(t) + 1, EventKind.cv_target, 0, float(sp[t])
        events.append(ev)
    cfg.events = events
    if disturbance is not None:
        cfg.output_disturbance = lead_in(disturbance)
    if valve_noise is not None:
        cfg.position_noise = lead_in(valve_noise)
    res = simulate_closed_loop(cfg)
    return {"op": res.u[1:, 0], "pv": res.y[1:, 0], "sp": sp, "position": res.u_actual[1:, 0]}

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
