"""Reference PI-loop simulator in plain NumPy (for tests and studies; not product code).

A single loop sampled every Ts: process K e^(-theta s) / (tau s + 1) discretised exactly with a
zero-order hold (a dead time between samples included), an additive disturbance
v = sigma / (1 - c q^-1) e, PV = process output + v, and a positional PI controller acting
on the same sample's PV (OP(t) reacts to PV(t): the feedback that makes lag 0 misleading),
OP clipped to its range. Written from the equations, independent of mpmpp's C++ simulator.
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

    def pi_tuning(self, ts: float) -> tuple[float, float]:
        """IMC / lambda tuning (kc = tau / (K (lambda + theta)), Ti = tau), lambda = max(tau, 2 Ts):
        a typical moderately tuned plant loop; the sign of kc follows the process gain."""
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


def foptd_coefficients(loop: Loop, ts: float):
    """(a, b0, b1, d): y(t) = a y(t-1) + b0 u(t-d) + b1 u(t-d-1), the exact ZOH discretisation."""
    m, frac = divmod(loop.dead_time_s / ts, 1.0)
    a = np.exp(-ts / loop.time_constant_s) if loop.time_constant_s > 0 else 0.0
    af = a ** (1.0 - frac)
    return a, loop.gain * (1.0 - af), loop.gain * (af - a), int(m) + 1


def simulate(loop: Loop, seed: int, rows: int = 751, ts: float = 10.0, setpoint_steps: bool = False,
             step_size: float | None = None, op0: float = 50.0, pv0: float = 20.0) -> pd.DataFrame:
    """One record: time, OP, PV, PV_sp. With ``setpoint_steps`` the setpoint alternates +-step_size
    (default 4 disturbance sds of PV) every 20 minutes."""
    rng = np.random.default_rng(seed)
    a, b0, b1, d = foptd_coefficients(loop, ts)
    kc, ti = loop.pi_tuning(ts)
    warm = 200  # settle the disturbance and controller before the record starts
    n = rows + warm
    e = rng.standard_normal(n) * loop.noise_sd
    v = np.zeros(n)
    for t in range(1, n):
        v[t] = loop.noise_pole * v[t - 1] + e[t]
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
    for t in range(n):
        if t >= 1:
            x[t] = a * x[t - 1]
            if t - d >= 0:
                x[t] += b0 * (op[t - d] - op0)
            if t - d - 1 >= 0:
                x[t] += b1 * (op[t - d - 1] - op0)
        pv[t] = pv0 + x[t] + v[t]
        err = sp[t] - pv[t]
        integral += kc * ts / ti * err
        op[t] = np.clip(op0 + kc * err + integral, *loop.op_span)
    keep = slice(warm, n)
    return pd.DataFrame({"time": np.arange(rows) * ts, "OP": op[keep], "PV": pv[keep], "PV_sp": sp[keep]})
