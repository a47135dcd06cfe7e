"""What a loop record's storage hides (historian compression, coarse quantization) and where
it holds no closed loop (a signal pinned at a limit).

A historian that stores a value only when it moves by more than a deviation and rebuilds the
record by holding or by straight lines between the stored points (boxcar / swinging-door
compression), or a coarse transmitter or A/D resolution, replaces the small moves every
stiction test reads with flat or straight stretches. Thornhill, Choudhury and Shah (2004, The
impact of compression on data-driven process analyses, J. Process Control 14) show that such
records make valve tests both miss and invent nonlinearity. On the stiction benchmark's loops
(docs/stiction.md) swinging-door compression at 0.3 of the PV's standard deviation lowered the
fit's recall and in one probe called 11 of 12 linear loops sticky. An uncompressed noisy signal
almost never repeats a value or lies exactly on the line through its neighbours, so the shares
of such samples tell a compressed or quantized record; the report says so beside the verdict.
"""
from __future__ import annotations

import numpy as np

# Share of samples above which a signal reads as held / interpolated (a noisy measurement
# stored as sampled has ~0 of either; compression at a deviation of 0.1 standard deviations
# already interpolates about a quarter of the samples).
NOTABLE_SHARE = 0.2
# Share of samples pinned at a limit above which the record says so: a noisy signal never
# returns to its exact extreme; an OP saturated for a twentieth of a 2 h record is an open loop
# for 6 min.
PINNED_SHARE = 0.05
MIN_LEVELS = 20


def repeated_share(x: np.ndarray) -> float:
    """Share of samples equal to the one before (held or quantized), not counting those at the
    record's smallest or largest value (an OP saturated at its limit repeats it legitimately)."""
    if len(x) < 2:
        return 0.0
    inside = (x[1:] > x.min()) & (x[1:] < x.max())
    return float(np.mean((np.diff(x) == 0.0) & inside))


def pinned_share(x: np.ndarray) -> tuple[float, float]:
    """(share, value): the share of samples at the record's largest or smallest value, on the
    side where it is larger, and that value; 0 where that value is not a pile-up (held no more
    often than twice the next value inward) or the record has fewer than MIN_LEVELS values (too
    coarse to tell a limit from a quantization step). A controller output saturated at a limit
    of its range (or a transmitter at the end of its range) returns to it again and again, and
    the loop is open while it sits there; a noisy signal reaches its exact extreme once."""
    levels, counts = np.unique(x, return_counts=True)
    if len(levels) < MIN_LEVELS:
        return 0.0, float("nan")
    sides = [(counts[k] / len(x), levels[k]) for k, inward in ((-1, -2), (0, 1)) if counts[k] > 2 * counts[inward]]
    return max(sides, default=(0.0, float("nan")))


def _at_largest_move(x: np.ndarray) -> np.ndarray:
    """Per move of x: whether its size is the record's largest (to rounding)."""
    d1 = np.abs(np.diff(x))
    scale = max(float(np.ptp(x)), np.finfo(float).tiny)
    return np.abs(d1 - d1.max()) <= 1e-9 * scale


def rate_limited_share(x: np.ndarray) -> float:
    """Share of the moves of x that are its largest move: an OP held to a rate or move limit
    (an MPC's move limit, a DMC clipping its moves, a positioner's slew rate) moves by that limit
    again and again, where a free OP's largest move happens once."""
    if len(x) < 2 or np.ptp(x) == 0:
        return 0.0
    return float(np.mean(_at_largest_move(x)))


def interpolated_share(x: np.ndarray) -> float:
    """Share of interior samples on the straight line through their neighbours that are not
    also flat (linear interpolation between stored points), to rounding. Samples reached and
    left at the signal's largest move per sample are not counted: an OP ramping at its rate
    limit (an MPC's move limit, a positioner's slew rate) lies on a line as sampled, where the
    segments of an interpolated record have slopes of every size (on the scenario families'
    MPC loops with binding move limits 37-62 % of the OP's samples were such ramps)."""
    if len(x) < 3:
        return 0.0
    d1 = np.diff(x)
    d2 = np.diff(x, 2)
    scale = max(float(np.ptp(x)), np.finfo(float).tiny)
    on_line = np.abs(d2) <= 1e-9 * scale
    moving = (d1[1:] != 0.0) | (d1[:-1] != 0.0)
    at_rate = _at_largest_move(x)
    return float(np.mean(on_line & moving & ~(at_rate[1:] & at_rate[:-1])))


def record_notes(signals: dict) -> list[str]:
    """One note per signal (name -> values) that looks held, quantized, interpolated, rate
    limited or pinned at a limit."""
    notes = []
    for name, x in signals.items():
        x = np.asarray(x, dtype=float)
        held, line = repeated_share(x), interpolated_share(x)
        if line > NOTABLE_SHARE:
            notes.append(f"{name} lies on straight lines between its neighbours in {100 * line:.0f} % of the "
                         f"samples: a historian record compressed with interpolation; stiction tests on "
                         f"compressed data can both miss and invent a valve fault (export it uncompressed)")
        limited = rate_limited_share(x)
        if limited > NOTABLE_SHARE:
            notes.append(f"{name} moves by its largest step in {100 * limited:.0f} % of the samples: a rate or move "
                         f"limit (an MPC's move limit, a positioner's slew rate); a valve fit reads such moves as "
                         f"stick-slip, so no valve fault is reported from this record")
        pinned, value = pinned_share(x)
        if pinned > PINNED_SHARE:
            side = "largest" if value == x.max() else "smallest"
            notes.append(f"{name} sits at {value:.6g}, its {side} value, in {100 * pinned:.0f} % of the samples: a "
                         f"limit (a controller output saturated, a transmitter at the end of its range); the loop "
                         f"is open there and those rows tell nothing of the valve")
        if held > NOTABLE_SHARE:
            notes.append(f"{name} repeats its previous value in {100 * held:.0f} % of the samples: a quantized "
                         f"or hold-compressed record; small valve moves are not visible in it")
    return notes
