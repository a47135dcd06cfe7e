"""A process channel read as first order plus dead time: gain, time constant and dead time in
seconds, the way control engineers state a loop's dynamics.

Exact for the channels ``TransferFunction.from_foptd`` makes (zero-order hold, also with a
dead time that is not a whole number of samples); any other stable channel gets the FOPTD
that matches its step response at the dead time and at 63% of the final value.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# Step response length for the approximate reading: the slowest pole decays to e^-12.
_SETTLING_TIME_CONSTANTS = 12
_MAX_STEP_SAMPLES = 1_000_000


@dataclass(frozen=True)
class Foptd:
    gain: float
    time_constant_s: float
    dead_time_s: float
    exact: bool  # False: fitted to the step response (higher order, zeros, ...)

    def __str__(self) -> str:
        text = f"gain {self.gain:.4g}, time constant {self.time_constant_s:.4g} s, dead time {self.dead_time_s:.4g} s"
        return text if self.exact else text + " (approximate: step-response fit)"


def _taps(g) -> tuple[np.ndarray, int]:
    """Numerator without leading/trailing zero taps, and the delay including the leading ones."""
    num = np.asarray(g.num, dtype=float)
    nz = np.flatnonzero(num)
    if nz.size == 0:
        return num[:0], g.delay
    return num[nz[0]:nz[-1] + 1], g.delay + int(nz[0])


def _exact(num: np.ndarray, den: np.ndarray, delay: int, ts: float) -> Foptd | None:
    """Inverse of the zero-order-hold discretisation of K e^(-theta s) / (tau s + 1): the channel
    read by ``foptd_reading`` within the stricter form a model file's FOPTD channel has (a pole in
    (0, 1), a delay of a sample or more, the dead time's fraction strictly inside a sample)."""
    if len(den) == 1 and len(num) == 1:
        return Foptd(num[0] / den[0], 0.0, delay * ts, True)
    if len(den) != 2 or delay < 1 or len(num) > 2:
        return None
    a = -den[1] / den[0]
    if not 0.0 < a < 1.0:
        return None
    b = num / den[0]
    if len(b) == 2:
        gain = b.sum() / (1.0 - a)
        if gain == 0.0:   # a zero-gain (washout) channel is no delayed first order
            return None
        # b0 = K (1 - a^(1-f)), b1 = K (a^(1-f) - a) (modified z-transform): a^(1-f) in (a, 1)
        if not a < 1.0 - b[0] / gain < 1.0:
            return None
    return Foptd(*foptd_reading(b, np.array([1.0, -a]), delay, ts), True)


def _from_step(g, delay: int, ts: float) -> Foptd | None:
    """Dead time where the step response leaves zero, time constant where it reaches 63%."""
    if not g.is_stable():
        return None
    poles = np.abs(np.asarray(g.poles()))
    slowest = poles.max() if poles.size else 0.0
    settle = 1 if slowest == 0 else math.ceil(_SETTLING_TIME_CONSTANTS / -math.log(slowest))
    n = min(delay + len(g.num) + settle + 2, _MAX_STEP_SAMPLES)
    step = np.asarray(g.step(n))
    gain = g.dc_gain()
    if gain == 0 or not np.isfinite(gain):
        return None
    moved = np.flatnonzero(np.abs(step) > 1e-9 * abs(gain))
    if moved.size == 0:   # no visible response within the window (a gain far beyond its transient)
        return None
    # A ZOH lag first moves one sample after its dead time.
    dead = max(int(moved[0]) - 1, 0) * ts
    frac = step / gain
    k = int(np.argmax(frac >= 1.0 - math.exp(-1.0)))
    t63 = k * ts if k == 0 else (k - 1 + (1.0 - math.exp(-1.0) - frac[k - 1]) / (frac[k] - frac[k - 1])) * ts
    return Foptd(gain, max(t63 - dead, 0.0), dead, False)


def foptd_reading(b, f, delay, ts):
    """(K, tau, theta) of G = q^-delay (b0 + b1 q^-1) / (1 + f1 q^-1), the inverse of the ZOH
    discretisation (docs/formats.md), for the parameters ``identify``'s first-order class fits
    (looser than ``_exact``, which reads a model file's channel); None when G is not of that form
    (pole outside (0, 1) is allowed down to 0: tau below the sample resolution; b1 / (b0 + b1)
    outside [0, 1) is not a dead time)."""
    a = -f[1]
    if not (a < 1.0) or b.sum() == 0.0:
        return None
    gain = b.sum() / (1.0 - a)
    tau = -ts / np.log(a) if a > 0 else 0.0
    share = b[1] / b.sum() if len(b) > 1 else 0.0
    if not (-1e-9 <= share < 1.0):
        return None
    if len(b) > 1 and 0 < a:
        frac = 1.0 - np.log(a + (1.0 - a) * share) / np.log(a)
    else:
        frac = share  # a pure gain: the dead time splits linearly between the two samples
    return gain, tau, (delay - 1 + frac) * ts


def integrating_reading(b, f, delay, ts):
    """(K, tau, theta) of the differenced channel G' = q^-delay (b0 + b1 q^-1) / F, F = 1 or
    1 - a q^-1, of K e^(-theta s) / (s (tau s + 1)); K is the rate gain (per second). Without a
    lag the ZOH gives b0 = K Ts (1 - phi), b1 = K Ts phi for theta = (delay - 1 + phi) Ts, exactly.
    With a lag, theta matches the first moment: the mean delay of G' in samples,
    delay + b1 / (b0 + b1) + a / (1 - a), is (theta + tau) / Ts + 1 for the continuous system
    under a ZOH (the pulse and the sampling window each add half a sample), exact for any theta.
    None when the pole is not in [0, 1), b1 / (b0 + b1) is outside [0, 1) or theta < 0."""
    a = -f[1] if len(f) > 1 else 0.0
    if not (0.0 <= a < 1.0) or b.sum() == 0.0:
        return None
    share = b[1] / b.sum() if len(b) > 1 else 0.0
    if not (-1e-9 <= share < 1.0):
        return None
    tau = -ts / np.log(a) if a > 0 else 0.0
    theta = (delay - 1 + share + a / (1.0 - a)) * ts - tau
    if theta < -1e-9 * ts:
        return None
    return b.sum() / ((1.0 - a) * ts), tau, max(theta, 0.0)


@dataclass(frozen=True)
class Integrating:
    rate_gain: float  # output units per second per input unit
    time_constant_s: float
    dead_time_s: float

    def __str__(self) -> str:
        lag = f", time constant {self.time_constant_s:.4g} s" if self.time_constant_s > 0 else ""
        return f"integrating, rate gain {self.rate_gain:.4g} per s{lag}, dead time {self.dead_time_s:.4g} s"


def integrating_parameters(g, sample_time_s: float) -> Integrating | None:
    """``g`` with one pole at 1 (the integrating channels ``identify`` writes) as rate gain,
    lag and dead time of K e^(-theta s) / (s (tau s + 1)); None for any other channel."""
    num, delay = _taps(g)
    den = np.asarray(g.den, dtype=float) / g.den[0]
    if num.size == 0 or len(den) < 2 or len(den) > 3 or len(num) > 2:
        return None
    f, rest = np.polydiv(den, [1.0, -1.0])  # den = (1 - q^-1) f, coefficients in q^-1
    if not np.allclose(rest, 0.0, atol=1e-9):
        return None
    reading = integrating_reading(num, f, delay, sample_time_s)
    return None if reading is None else Integrating(*reading)


def dead_time_s(g, sample_time_s: float) -> float | None:
    """The dead time in seconds of ``g`` read as first order plus dead time (``foptd_parameters``)
    or as an integrator (``integrating_parameters``): the FOPTD form's ``dead_time_s``, one sample
    less than the discrete form's first lag under the zero-order hold. None when neither reads."""
    reading = foptd_parameters(g, sample_time_s) or integrating_parameters(g, sample_time_s)
    return None if reading is None else reading.dead_time_s


def foptd_parameters(g, sample_time_s: float) -> Foptd | None:
    """``g`` (a discrete TransferFunction at ``sample_time_s``) as gain, time constant and dead
    time; None where no such reading exists (unstable or integrating channels, zero gain)."""
    num, delay = _taps(g)
    if num.size == 0:
        return None
    den = np.asarray(g.den, dtype=float)
    return _exact(num, den, delay, sample_time_s) or _from_step(g, delay, sample_time_s)
