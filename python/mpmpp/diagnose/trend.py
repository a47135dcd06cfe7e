"""Best onset of an additive step + ramp in the one-step error (a drift on the output)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._core import TransferFunction

RIDGE = 1e-12                # keeps the 3x3 normal equations solvable before any step moved


@dataclass
class TrendFit:
    onset: int               # first sample of the step + ramp
    drop: float              # drop of the residual sum of squares against a constant
    trend: np.ndarray        # the fitted step + ramp part, filtered by H^-1 (N long)


def trend_fit(e: np.ndarray, ok: np.ndarray, hinv: TransferFunction, first_onset: int, grid: int,
              earliest: int) -> TrendFit:
    """Least squares of the one-step error e on H^-1 [1, step(t - k), ramp(t - k)] for onsets
    k >= ``earliest`` on a grid (the AR correction is left out: it would whiten a drift away).
    Without a drop, the onset is ``first_onset``.

    The regressors for onset k are one fixed pair of sequences (s, r) = H^-1 [step, ramp]
    delayed by k, so every entry of the normal equations is a cross-correlation of the data
    (mask, mask * e) with s, r, s^2, r^2 or s r at lag k: all onsets cost a few FFTs."""
    n = len(e)
    onsets = np.arange(earliest, n - 2 * grid, grid)
    s = hinv.filter(np.ones(n))
    r = hinv.filter(np.arange(n, dtype=float) / n)
    w = ok.astype(float)
    we = w * e
    rss0 = np.sum((e[ok] - e[ok].mean()) ** 2)
    best = TrendFit(first_onset, 0.0, np.zeros(n))
    if len(onsets) == 0:
        return best
    lag = _lagged_sums([w, we], [s, r, s * s, r * r, s * r], n)
    ws, wr, wss, wrr, wsr = (lag[0][j][onsets] for j in range(5))
    es, er = lag[1][0][onsets], lag[1][1][onsets]
    gram = np.empty((len(onsets), 3, 3))
    gram[:, 0, 0] = w.sum()
    gram[:, 0, 1] = gram[:, 1, 0] = ws
    gram[:, 0, 2] = gram[:, 2, 0] = wr
    gram[:, 1, 1] = wss
    gram[:, 1, 2] = gram[:, 2, 1] = wsr
    gram[:, 2, 2] = wrr
    rhs = np.stack([np.full(len(onsets), we.sum()), es, er], axis=1)
    coef = np.linalg.solve(gram + RIDGE * np.eye(3), rhs[:, :, None])[:, :, 0]
    # residual sum of squares e'e - 2 c'X'e + c'X'X c
    rss = np.sum(we * e) - 2.0 * np.sum(coef * rhs, axis=1) + np.einsum("ki,kij,kj->k", coef, gram, coef)
    drop = rss0 - rss
    j = int(np.argmax(drop))
    if not drop[j] > 0.0:
        return best
    k = int(onsets[j])
    trend = np.zeros(n)
    trend[k:] = coef[j, 1] * s[: n - k] + coef[j, 2] * r[: n - k]
    return TrendFit(k, float(drop[j]), trend)


def _lagged_sums(data: list[np.ndarray], kernels: list[np.ndarray], n: int) -> list[list[np.ndarray]]:
    """[i][j][k] = sum_{t >= k} data_i[t] kernels_j[t - k] for every lag k < n (FFT, zero-padded
    so the circular correlation is the linear one)."""
    m = 1 << (2 * n - 1).bit_length()
    fk = [np.conj(np.fft.rfft(b, m)) for b in kernels]
    out = []
    for a in data:
        fa = np.fft.rfft(a, m)
        out.append([np.fft.irfft(fa * f, m)[:n] for f in fk])
    return out
