"""A periodic disturbance from outside a loop: its frequency, and the data without it.

An oscillation that enters a loop from outside (an upstream loop cycling, a compressor surge,
a day-night cycle) is a disturbance the low-order AR noise models of ``identify`` whiten poorly,
and in closed loop the OP oscillates with it: a process channel delayed by part of the period
then fits the disturbance's cycle, and the dead time comes out far too long with a narrow
interval (the stiction study's loops with an external sinusoid, 2 h at 10 s: 60-440 s for a
truth of 10-40 s). Modelled as y = G u + a sin(w t) + b cos(w t) + H e, the sinusoid's two
coefficients enter linearly, so fitting G on y and u with their component at w projected out
is the joint least-squares fit (Frisch-Waugh; a linear filter maps a sinusoid to one of the
same frequency, so G u's share at w is absorbed by the same two columns).
"""
from __future__ import annotations

import numpy as np

# Periods searched: from 4 samples (a visible cycle) to a quarter of the record (at least four
# cycles make an oscillation).
SHORTEST_PERIOD = 4
FEWEST_CYCLES = 4
ZERO_PADDING = 16


def dominant_frequency(x: np.ndarray) -> float:
    """Frequency (cycles per sample) of the periodogram's peak of x (Hann window, 16-fold zero
    padding), among periods from SHORTEST_PERIOD samples to a FEWEST_CYCLES-th of the record."""
    n = len(x)
    m = ZERO_PADDING * n
    power = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(n), m)) ** 2
    f = np.fft.rfftfreq(m)
    band = (f >= FEWEST_CYCLES / n) & (f <= 1.0 / SHORTEST_PERIOD)
    return float(f[band][np.argmax(power[band])])


def sinusoid_columns(rows: np.ndarray, frequency: float) -> np.ndarray:
    """[1, sin, cos] at ``frequency`` (cycles per sample) on the sample grid's row numbers
    ``rows`` (a record with gaps keeps the cycle's phase across them)."""
    phase = 2.0 * np.pi * frequency * np.asarray(rows, float)
    return np.column_stack([np.ones(len(phase)), np.sin(phase), np.cos(phase)])


def without_sinusoid(x: np.ndarray, rows: np.ndarray, frequency: float) -> tuple[np.ndarray, np.ndarray]:
    """(x less its least-squares sinusoid at ``frequency``, the sinusoid's amplitude per column);
    x is one column or several. The mean is fitted beside it and kept."""
    columns = sinusoid_columns(rows, frequency)
    two_d = np.asarray(x, float).reshape(len(columns), -1)
    coef = np.linalg.lstsq(columns, two_d, rcond=None)[0]
    periodic = columns[:, 1:] @ coef[1:]
    return (two_d - periodic).reshape(np.shape(x)), np.hypot(coef[1], coef[2])
