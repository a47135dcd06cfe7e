"""Kano's stick-band test on the OP-PV plot (Kano, Maruta, Kugemoto & Shimizu 2004,
"Practical model and detection algorithm for valve stiction", IFAC DYCOPS).

A sticking valve shows as sections where the OP keeps moving in one direction while the PV
(our proxy for the valve position) stays put. The index is the fraction of the record spent
in such sections with an OP travel above a minimum band, sized by the mean OP travel there.
"""
from __future__ import annotations

import numpy as np

THRESHOLD = 0.035       # chosen on the TUNING families of studies/stiction_benchmark.py
PV_STILL = 0.5          # |dPV| below this fraction of std(dPV) counts as "PV still"
MIN_SECTION = 3         # samples


def kano_index(op, pv) -> tuple[float, float]:
    """(fraction of samples in stick sections, mean OP travel over a stick section)."""
    u = np.asarray(op, float)
    y = np.convolve(np.asarray(pv, float), np.ones(3) / 3, mode="valid")
    u = u[1:-1]
    du, dy = np.diff(u), np.diff(y)
    still = np.abs(dy) < PV_STILL * np.std(dy)
    moving = np.abs(du) > 0
    stuck_samples = 0
    travels = []
    k = 0
    n = len(du)
    band = 0.5 * np.std(u)
    while k < n:
        if still[k] and moving[k]:
            direction = np.sign(du[k])
            j = k
            while j < n and still[j] and np.sign(du[j]) == direction:
                j += 1
            travel = abs(u[j] - u[k])
            if j - k >= MIN_SECTION and travel > 0.2 * band:
                stuck_samples += j - k
                travels.append(travel)
            k = j
        else:
            k += 1
    return stuck_samples / n, float(np.mean(travels)) if travels else 0.0


def kano_test(op, pv) -> tuple[bool, dict]:
    fraction, band = kano_index(op, pv)
    return fraction > THRESHOLD, {"stick_fraction": fraction, "stick_band": band}
