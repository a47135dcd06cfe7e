"""A small closed loop written in NumPy for the diagnosis tests: a SISO (or 1-output, 2-input)
plant under an integral controller, with an optional change at `onset`. Independent of the
project's MPC simulator so the tests check the diagnosis, not the simulator."""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.signal import lfilter

import mpmpp

TS = 5.0
G = ([0.1], [1.0, -0.9], 6)          # num, den, delay
H = ([1.0, -0.3], [1.0, 0.5])


def model(extra_input=False):
    return mpmpp.Model("test loop", TS, ["u"], ["y"],
                       {"y": {"u": mpmpp.TransferFunction(*G)}}, {"y": mpmpp.TransferFunction(*H)})


def simulate(n=8000, seed=0, onset=None, gain=1.0, noise_den_after=None, w_gain=0.0, drift_rate=0.0,
             gain_reference=0.0):
    """y = G_true u + H e (+ w through 0.5/(1-0.8q^-1) q^-4), u from an integral controller
    on y plus a small dither-free setpoint schedule. From `onset` on: gain x `gain` about the
    input value `gain_reference` (G_true (u - ref) + G ref: a plant whose gain changes about
    another operating point than the loop's moves the output's level at the onset), noise
    denominator `noise_den_after`, drift of `drift_rate` per sample."""
    rng = np.random.default_rng(seed)
    e = 0.05 * rng.standard_normal(n)
    w = lfilter([1.0], [1.0, -0.98], 0.02 * rng.standard_normal(n))
    onset = n if onset is None else onset
    v = lfilter(*H, e)
    if noise_den_after is not None:
        v[onset:] = lfilter(H[0], noise_den_after, e)[onset:]
    v += drift_rate * np.maximum(np.arange(n) - onset, 0)
    v += w_gain * lfilter([0, 0, 0, 0, 0.5 * 0.2], [1.0, -0.8], w)
    num, den, d = G
    sp = np.where((np.arange(n) // 600) % 2 == 0, 0.0, 0.3)   # operator setpoint moves
    u = np.zeros(n)
    x = np.zeros(n)          # process part of y
    y = np.zeros(n)
    a = -den[1]
    for t in range(n):
        k = gain if t >= onset else 1.0
        if t >= 1:
            x[t] = a * x[t - 1] + (num[0] * (k * (u[t - d] - gain_reference) + gain_reference)
                                   if t - d >= 0 else 0.0)
        y[t] = x[t] + v[t]
        u[t] = (u[t - 1] if t else 0.0) + 0.04 * (sp[t] - y[t])
    # the gain factor multiplies the input term only from onset on: x carries the state
    return pd.DataFrame({"time": TS * np.arange(n), "u": u + 100.0, "y": y + 20.0, "w": w + 5.0,
                         "y_sp": sp + 20.0})
