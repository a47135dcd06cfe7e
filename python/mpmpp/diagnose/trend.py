"""Best onset of an additive step + ramp in the one-step error (a drift on the output)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.fft

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
    Without a drop, the onset is ``first_onset``."""
    return TrendScan(ok, hinv, grid, earliest).fit(e, first_onset)


class TrendScan:
    """``trend_fit`` for any number of errors with one mask, H^-1 and onset grid.

    The regressors for onset k are one fixed pair of sequences (s, r) = H^-1 [step, ramp]
    delayed by k, so every entry of the normal equations is a cross-correlation of the data
    (mask, mask * e) with s, r, s^2, r^2 or s r at lag k: all onsets cost a few FFTs. Those of
    the mask (the Gram matrices) are formed once; an error costs one FFT and two inverse ones."""

    def __init__(self, ok: np.ndarray, hinv: TransferFunction, grid: int, earliest: int):
        n = len(ok)
        self.ok = ok
        self.onsets = np.arange(earliest, n - 2 * grid, grid)
        self.s = hinv.filter(np.ones(n))
        self.r = hinv.filter(np.arange(n, dtype=float) / n)
        self.w = ok.astype(float)
        if len(self.onsets) == 0:
            return
        # zero-padded to at least 2n - 1 (the circular correlation is then the linear one), to a
        # length of small prime factors: on a week at 5 s, 243,000 is 1.6x faster than 2^18
        self._size = scipy.fft.next_fast_len(2 * n - 1, real=True)
        s, r = self.s, self.r
        kernels = [np.conj(scipy.fft.rfft(b, self._size)) for b in (s, r, s * s, r * r, s * r)]
        self._sr = kernels[:2]
        ws, wr, wss, wrr, wsr = self._lagged(self.w, kernels)
        gram = np.empty((len(self.onsets), 3, 3))
        gram[:, 0, 0] = self.w.sum()
        gram[:, 0, 1] = gram[:, 1, 0] = ws
        gram[:, 0, 2] = gram[:, 2, 0] = wr
        gram[:, 1, 1] = wss
        gram[:, 1, 2] = gram[:, 2, 1] = wsr
        gram[:, 2, 2] = wrr
        self.gram = gram

    def _lagged(self, a: np.ndarray, kernels: list[np.ndarray]) -> list[np.ndarray]:
        """sum_{t >= k} a[t] kernel[t - k] at the onsets k, per kernel."""
        fa = scipy.fft.rfft(a, self._size)
        return [scipy.fft.irfft(fa * f, self._size)[: len(a)][self.onsets] for f in kernels]

    def fit(self, e: np.ndarray, first_onset: int) -> TrendFit:
        n, ok, w = len(e), self.ok, self.w
        we = w * e
        rss0 = np.sum((e[ok] - e[ok].mean()) ** 2)
        best = TrendFit(first_onset, 0.0, np.zeros(n))
        if len(self.onsets) == 0:
            return best
        es, er = self._lagged(we, self._sr)
        gram = self.gram
        rhs = np.stack([np.full(len(self.onsets), we.sum()), es, er], axis=1)
        normal = gram + RIDGE * np.eye(3)
        try:
            coef = np.linalg.solve(normal, rhs[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            # An onset whose step and ramp the mask leaves (numerically) collinear with the level:
            # a record cut by many lost samples (the PV lost every 250 rows of a day-long record
            # raised "Singular matrix"). Every onset then gets the minimum-norm solution, which for
            # a regular system is the one solve gives.
            coef = np.einsum("kij,kj->ki", np.linalg.pinv(normal, hermitian=True), rhs)
        # residual sum of squares e'e - 2 c'X'e + c'X'X c
        rss = np.sum(we * e) - 2.0 * np.sum(coef * rhs, axis=1) + np.einsum("ki,kij,kj->k", coef, gram, coef)
        drop = rss0 - rss
        j = int(np.argmax(drop))
        if not drop[j] > 0.0:
            return best
        k = int(self.onsets[j])
        trend = np.zeros(n)
        trend[k:] = coef[j, 1] * self.s[: n - k] + coef[j, 2] * self.r[: n - k]
        return TrendFit(k, float(drop[j]), trend)
