"""How far apart two channels are, in the terms a control engineer reads a model error: the
step-response difference over the settling horizon, relative to the reference channel's gain.
An integrating reference (a level) has no steady-state gain: its channels are compared by their
rate responses, the step responses of (1 - q^-1) G, relative to the reference's rate gain."""
from __future__ import annotations

import math

import numpy as np

from ._core import TransferFunction, without_integrators
from .integrating import integrates


def step_response_error(channel: TransferFunction | None, reference: TransferFunction) -> float:
    """RMS over the settling horizon of the step-response difference, relative to the
    reference channel's steady-state gain (a missing channel has a zero response)."""
    return float(np.sqrt(np.mean(_step_difference(channel, reference) ** 2)))


def step_response_deviation(channel: TransferFunction | None, reference: TransferFunction) -> float:
    """Largest step-response difference over the settling horizon, relative to the reference
    channel's steady-state gain: a gain ratio k gives |k - 1|; a new time constant or dead
    time the peak of its transient difference (the RMS dilutes it by the settled tail)."""
    return float(np.max(np.abs(_step_difference(channel, reference))))


def _step_difference(channel: TransferFunction | None, reference: TransferFunction) -> np.ndarray:
    if integrates(reference):
        channel = None if channel is None else (without_integrators(channel) if integrates(channel)
                                                else channel.series(TransferFunction([1.0, -1.0], [1.0])))
        reference = without_integrators(reference)
    horizon = settling_samples(reference, channel)
    s_ref = np.asarray(reference.step(horizon))
    s = np.zeros(horizon) if channel is None else np.asarray(channel.step(horizon))
    scale = max(abs(float(reference.dc_gain())), 1e-12)
    return (s_ref - s) / scale


def settling_samples(*channels) -> int:
    """Longest delay plus 5 of the slowest time constant (in samples) of the channels."""
    slowest, delay = 1.0, 0
    for g in channels:
        if g is None:
            continue
        delay = max(delay, int(g.delay))
        for p in np.abs(np.asarray(g.poles())):
            if 0.0 < p < 1.0:
                slowest = max(slowest, -1.0 / math.log(p))
    return int(min(delay + 5.0 * slowest + 10, 20000))
