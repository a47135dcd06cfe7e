"""The step + ramp trend fit of the diagnosis (mpmpp.diagnose.trend) by one least-squares
fit per onset: the plain NumPy reference of the test and the bench's named peer."""
import numpy as np


def brute_trend(e, ok, hinv, first_onset, grid, earliest):
    n = len(e)
    step0, ramp0 = hinv.filter(np.ones(n)), hinv.filter(np.arange(n) / n)
    rss0 = np.sum((e[ok] - e[ok].mean()) ** 2)
    best = (first_onset, 0.0)
    for k in range(earliest, n - 2 * grid, grid):
        x = np.column_stack([np.ones(n), np.r_[np.zeros(k), step0[: n - k]], np.r_[np.zeros(k), ramp0[: n - k]]])
        coef = np.linalg.lstsq(x[ok], e[ok], rcond=None)[0]
        drop = rss0 - np.sum((e[ok] - x[ok] @ coef) ** 2)
        if drop > best[1]:
            best = (k, drop)
    return best
