"""Reference PI-loop simulator in plain NumPy (for tests and studies; not product code).

A single loop sampled every Ts: process K e^(-theta s) / (tau s + 1) discretised exactly with a
zero-order hold (a dead time between samples included), an additive disturbance
v = sigma / (1 - c q^-1) e, PV = process output + v, and a positional PI controller acting
on the same sample's PV (OP(t) reacts to PV(t): the feedback that makes lag 0 misleading),
OP clipped to its range. Integrating loops (a level): process K e^(-theta s) / (s (tau s + 1))
(K the rate gain, PV units per s per OP unit; tau 0 for a pure integrator), simulated exactly on
a sub-grid of the sample time, and an unmeasured inflow disturbance,
v = sigma / ((1 - q^-1) (1 - c q^-1)) e, or (``inflow_disturbance`` false) the stationary one
above, as transmitter noise or a wavy surface gives. Written from the equations, independent of mpmpp's C++
simulator.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd


@dataclass(frozen=True)
class Loop:
    name: str
    gain: float              # PV units per OP %
    time_constant_s: float
    dead_time_s: float
    noise_sd: float          # sigma of the disturbance's white input (PV units)
    noise_pole: float        # c in v = sigma / (1 - c q^-1) e
    op_span: tuple = (0.0, 100.0)
    integrating: bool = False
    inflow_disturbance: bool = True  # integrating loops: the disturbance integrates too

    def pi_tuning(self, ts: float) -> tuple[float, float]:
        """IMC / lambda tuning (kc = tau / (K (lambda + theta)), Ti = tau), lambda = max(tau, 2 Ts):
        a typical moderately tuned plant loop; the sign of kc follows the process gain.
        Integrating: SIMC (Skogestad 2003), kc = 1 / (K (lambda + theta')), Ti = 4 (lambda + theta')
        with the lag counted as dead time, theta' = theta + tau + Ts / 2, and lambda = 3 theta'
        (a level loop tuned for averaging rather than tight control)."""
        if self.integrating:
            theta = self.dead_time_s + self.time_constant_s + ts / 2
            return 1.0 / (self.gain * 4 * theta), 16 * theta
        lam = max(self.time_constant_s, 2 * ts)
        theta = self.dead_time_s + ts / 2  # the sample-and-hold adds about half a sample
        kc = self.time_constant_s / (self.gain * (lam + theta)) if self.time_constant_s > 0 else 0.2 / self.gain
        return kc, max(self.time_constant_s, ts)


# Flow / level-like (slow lag) / pressure-like dynamics at 10 s sampling; the pressure loop has a
# negative gain (reverse-acting valve). Dead times are not whole samples.
FLOW = Loop("flow", 1.6, 25.0, 12.0, 0.05, 0.9)
LEVEL = Loop("level", 0.8, 400.0, 25.0, 0.03, 0.97)
PRESSURE = Loop("pressure", -2.5, 120.0, 35.0, 0.04, 0.95)
LOOPS = (FLOW, LEVEL, PRESSURE)
# Integrating levels (rate gain in % per s per OP %): a pure integrator, and one behind a 60 s lag
# (a level fed through a vessel or a slow valve).
TANK = Loop("tank level", 0.004, 0.0, 15.0, 0.01, 0.8, integrating=True)
TANK_LAG = Loop("tank level, lag", 0.004, 60.0, 25.0, 0.01, 0.8, integrating=True)
TANK_NOISY = Loop("tank level, transmitter noise", 0.004, 0.0, 15.0, 0.1, 0.8, integrating=True,
                  inflow_disturbance=False)
INTEGRATING_LOOPS = (TANK, TANK_LAG, TANK_NOISY)


def foptd_coefficients(loop: Loop, ts: float):
    """(a, b0, b1, d): y(t) = a y(t-1) + b0 u(t-d) + b1 u(t-d-1), the exact ZOH discretisation."""
    m, frac = divmod(loop.dead_time_s / ts, 1.0)
    a = np.exp(-ts / loop.time_constant_s) if loop.time_constant_s > 0 else 0.0
    af = a ** (1.0 - frac)
    return a, loop.gain * (1.0 - af), loop.gain * (af - a), int(m) + 1


def simulate(loop: Loop, seed: int, rows: int = 751, ts: float = 10.0, setpoint_steps: bool = False,
             step_size: float | None = None, op0: float = 50.0, pv0: float = 20.0,
             gain_change: tuple[int, float] | None = None, oscillation: tuple[float, float] | None = None) -> pd.DataFrame:
    """One record: time, OP, PV, PV_sp. With ``setpoint_steps`` the setpoint alternates +-step_size
    (default 4 disturbance sds of PV) every 20 minutes. ``gain_change`` (row, factor): from that
    row of the record on, the process gain is ``factor`` times the loop's (self-regulating loops).
    ``oscillation`` (amplitude, period_s): a sinusoid added to the disturbance (an upstream loop
    cycling), its phase drawn from the seed."""
    rng = np.random.default_rng(seed)
    kc, ti = loop.pi_tuning(ts)
    warm = 200  # settle the disturbance and controller before the record starts
    n = rows + warm
    e = rng.standard_normal(n) * loop.noise_sd
    v = np.zeros(n)
    for t in range(1, n):
        v[t] = loop.noise_pole * v[t - 1] + e[t]
    if loop.integrating and loop.inflow_disturbance:
        v = np.cumsum(v)
    if oscillation is not None:
        amplitude, period_s = oscillation
        v = v + amplitude * np.sin(2 * np.pi * np.arange(n) * ts / period_s + rng.uniform(0, 2 * np.pi))
    sp = np.full(n, pv0)
    if setpoint_steps:
        size = step_size if step_size is not None else 4 * loop.noise_sd / np.sqrt(1 - loop.noise_pole**2)
        period = int(round(1200 / ts))
        k = np.maximum(np.arange(n) - warm, 0) // period
        sp = pv0 + np.where(np.arange(n) < warm, 0.0, np.where(k % 2 == 1, size, 0.0))
    x = np.zeros(n)          # process deviation from its steady state at op0
    op = np.full(n, op0)
    pv = np.full(n, pv0)
    integral = 0.0
    process = _Integrator(loop, ts) if loop.integrating else None
    if process is None:
        a, b0, b1, d = foptd_coefficients(loop, ts)
    for t in range(n):
        if process is not None:
            x[t] = process.step(op[t - 1] - op0 if t >= 1 else 0.0)
        elif t >= 1:
            k = gain_change[1] if gain_change is not None and t >= warm + gain_change[0] else 1.0
            x[t] = a * x[t - 1]
            if t - d >= 0:
                x[t] += k * b0 * (op[t - d] - op0)
            if t - d - 1 >= 0:
                x[t] += k * b1 * (op[t - d - 1] - op0)
        pv[t] = pv0 + x[t] + v[t]
        err = sp[t] - pv[t]
        integral += kc * ts / ti * err
        op[t] = np.clip(op0 + kc * err + integral, *loop.op_span)
    keep = slice(warm, n)
    return pd.DataFrame({"time": np.arange(rows) * ts, "OP": op[keep], "PV": pv[keep], "PV_sp": sp[keep]})


class _Integrator:
    """K e^(-theta s) / (s (tau s + 1)) driven by a zero-order hold, exact on a sub-grid of
    SUB steps per sample (theta rounded to the sub-grid): the lag state x follows
    x(t + h) = x e^(-h / tau) + (1 - e^(-h / tau)) K u, and the level gains the integral of x over
    the step, K u h - tau (x(t + h) - x(t)) (from tau dx/dt = K u - x)."""

    SUB = 50

    def __init__(self, loop: Loop, ts: float):
        self.h = ts / self.SUB
        self.tau, self.gain = loop.time_constant_s, loop.gain
        self.lag = int(round(loop.dead_time_s / self.h))
        self.queue = [0.0] * self.lag      # input on the sub-grid, oldest first
        self.x = self.level = 0.0

    def step(self, u: float) -> float:
        """Level at the end of the sample in which the held input was u."""
        decay = np.exp(-self.h / self.tau) if self.tau > 0 else 0.0
        for _ in range(self.SUB):
            self.queue.append(u)
            w = self.queue.pop(0)
            x_next = self.x * decay + (1.0 - decay) * self.gain * w
            self.level += self.gain * w * self.h - self.tau * (x_next - self.x)
            self.x = x_next
        return self.level
