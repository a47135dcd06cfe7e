"""Candidate shapes of a process change: one channel replaced, from an onset on, by theta * S(q).

Shapes S: the model's channel (``gain``), the channel with a new time constant
(``time_constant``) or delay (``delay``), a unit-gain first-order-plus-delay channel from an
input the model says has none (``missing_coupling``) or from an extra data column
(``unmodeled_input``), or an additive ramp/step (``output_drift``), each on its grid. The
search that fits them is ``process``; their whitened responses are ``responses``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .._core import TransferFunction
from ..integrating import integrates
from ..signals import Signals

TIME_CONSTANT_FACTORS = (0.33, 0.5, 0.67, 0.8, 1.25, 1.5, 2.0, 3.0)
TIME_CONSTANT_BOUNDS = (0.2, 5.0)   # refinement bounds past the grid's ends
DELAY_RANGE = (-10, 15)      # new delay = model delay + this range (samples)
COUPLING_POLES = (0.0, 0.5, 0.8, 0.9, 0.95, 0.98)
# Delay >= 1: in closed loop u(t) may already react to y(t), a lag-0 channel would fit feedback.
COUPLING_DELAYS = range(1, 41)
NEW_CHANNEL_EFFECTS = ("missing_coupling", "unmodeled_input")
DRIFT_GRID_S = 1800.0
DRIFT_COLUMN = "(drift)"
DELAY_GRID_EFFECTS = ("delay", "missing_coupling", "unmodeled_input")


@dataclass
class Shape:
    """A candidate: channel (output <- column) replaced by theta * shape after an onset."""

    effect: str
    column: str
    kind: str                     # "input", "extra" or "drift"
    shape: TransferFunction       # theta = 1 means the shape itself
    nominal: TransferFunction | None
    label: float                  # the grid value (gain 1, time-constant factor, delay, pole, drift onset)
    params: int                   # fitted parameters incl. the grid choice (onset counted later)
    drive: np.ndarray = field(repr=False, default=None)   # the column the channel filters
    drift_form: str = ""          # "ramp" or "step" for an output drift (its drive is built on demand)
    scale_held: bool = False      # theta held at 1: a new dynamics that keeps the model's gain
    level_step: bool = False      # fitted with the output's level step at its onset (a gain change
                                  # about another operating point than the record's mean)

    def holding_scale(self) -> "Shape":
        """The same new dynamics with the model's gain kept (theta held at 1): one parameter fewer."""
        return dataclasses.replace(self, scale_held=True, params=self.params - 1)

    def scaled(self, theta: float) -> TransferFunction:
        """The channel theta * shape."""
        return TransferFunction(np.asarray(self.shape.num) * theta, self.shape.den, self.shape.delay)


def first_order_with_time_constant(g: TransferFunction, factor: float) -> TransferFunction | None:
    """g with every real pole p moved to p^(1/factor) (time constant times factor), DC gain kept;
    None without such poles, with a pole at 1 (an integrator has no time constant to scale) or
    with a DC gain of 0 (a washout channel: no gain to keep by scaling)."""
    poles = g.poles()
    if (len(poles) == 0 or np.any(np.abs(poles.imag) > 1e-9) or np.any(poles.real <= 0)
            or np.any(poles.real >= 1.0 - 1e-12) or np.asarray(g.num).sum() == 0.0):
        return None
    new_den = np.real(np.poly(poles.real ** (1.0 / factor)))
    scale = g.dc_gain() * new_den.sum() / g.num.sum()
    return TransferFunction(np.asarray(g.num) * scale, new_den, g.delay)


def first_lag(g: TransferFunction) -> int:
    """The first lag at which u reaches y through g: the delay plus leading zero numerator terms."""
    nonzero = np.flatnonzero(np.asarray(g.num) != 0.0)
    return g.delay + (int(nonzero[0]) if len(nonzero) else 0)


def drift_drive(length: int, onset: int, form: str, hour: float) -> np.ndarray:
    """A drift starting at ``onset`` (may be negative: started before the first sample):
    ramp max(t - onset, 0) in hours, or step (t > onset)."""
    t = np.maximum(np.arange(length) - onset, 0.0)
    return t / hour if form == "ramp" else (t > 0).astype(float)


def _new_channel_shapes(effect: str, column: str, kind: str, drive: np.ndarray) -> list[Shape]:
    """A channel the model lacks, from ``column``: unit-gain first order plus delay on the grid
    of poles and delays (pole by pole, delays in order: the lines the search runs along)."""
    return [Shape(effect, column, kind, TransferFunction([1.0 - p], [1.0, -p], d), None, d, 3, drive)
            for p in COUPLING_POLES for d in COUPLING_DELAYS]


def process_shapes(sig: Signals, i: int) -> list[Shape]:
    shapes = []
    for j, name in enumerate(sig.inputs):
        g, u = sig.rows[i][j], sig.u[:, j]
        # a channel written as zero (gain 0) says what an absent one says: searched as one the
        # model lacks (theta * 0 would be no candidate at all)
        if g is None or g.is_zero():
            shapes += _new_channel_shapes("missing_coupling", name, "input", u)
            continue
        gain = Shape("gain", name, "input", g, g, 1.0, 1, u)
        shapes.append(gain)
        if not integrates(g):   # an integrator's gain changed about another point ramps its output
            shapes.append(dataclasses.replace(gain, level_step=True, params=2))
        for f in TIME_CONSTANT_FACTORS:
            s = first_order_with_time_constant(g, f)
            if s is not None:
                shapes.append(Shape("time_constant", name, "input", s, g, f, 2, u))
        lag, num = first_lag(g), np.trim_zeros(np.asarray(g.num, float), "f")
        for dd in range(*DELAY_RANGE):
            # no lag 0: in closed loop u(t) may already react to y(t), as for the couplings
            if dd != 0 and len(num) and lag + dd >= 1:
                shapes.append(Shape("delay", name, "input", TransferFunction(num, g.den, lag + dd),
                                    g, lag + dd, 2, u))
    # Output drift competes in the same pool: an additive ramp or step on the output from
    # onset tau on (grid of DRIFT_GRID_S). In closed loop the controller cancels a drift with
    # its inputs, so a drift otherwise poses as a channel change fitted to that compensation.
    n = len(sig.time_s)
    grid = max(int(round(DRIFT_GRID_S / sig.sample_time_s)), 1)
    for tau in range(0, max(n - 2 * grid, 1), grid):
        for form in ("ramp", "step"):
            shapes.append(Shape("output_drift", DRIFT_COLUMN, "drift", TransferFunction(), None, tau, 2,
                                drift_form=form))
    for k, name in enumerate(sig.extras):
        shapes += _new_channel_shapes("unmodeled_input", name, "extra", sig.z[:, k])
    return shapes
