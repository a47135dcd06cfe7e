"""Held-out gain of a candidate term in the one-step error when the AR noise correction is
refitted together with it, for every onset of a grid.

With e the one-step error of the nominal model (H^-1 (y - G u), its step + ramp disturbances
removed) and psi a candidate's H^-1-filtered contribution from onset k on, the candidate's error
is x_k = e - 1[t >= k] psi. Its AR(p) correction A_k is the least-squares fit of x_k on its own
p lags. Scoring a candidate after whitening with the AR fitted to e instead penalises it when
that AR has already absorbed what the candidate explains (a limit cycle, an actuator's
sticking phases): x_k is then less predictable by the nominal AR than e is, though far more
predictable by its own.

Everything the AR fit and its error need is the lag Gram matrix M = sum_t z_t z_t' of
z_t = (x_t, x_{t-1}, ..., x_{t-p}); with z^e and z^psi the lag vectors of e and psi,
M_k = M^e + sum_{t >= k} (z^psi z^psi' - z^e z^psi' - z^psi z^e'), a suffix sum per fold. (The
indicator is applied to the whole lag vector at t: exact except for the p rows after k.) The AR
fitted on one fold's M, a = argmin c' M c with c = (1, -a), is scored on the other fold's: the
held-out statistic n log(SSE_nominal / SSE_candidate), on the scale of a drop in the whitened
squared error (a chi-square statistic).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .whitening import AR_ORDER


def lag_vectors(x: np.ndarray, order: int = AR_ORDER) -> np.ndarray:
    """Rows z_t = (x_t, x_{t-1}, ..., x_{t-order}), zeros before the start."""
    n = len(x)
    z = np.zeros((n, order + 1))
    for k in range(order + 1):
        z[k:, k] = x[: n - k]
    return z


def ar_errors(gram: np.ndarray, score_gram: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For stacked lag Gram matrices (..., p+1, p+1): the AR fitted on ``gram`` and its
    squared-error sums c' G c on ``gram`` itself and on ``score_gram``."""
    a = np.linalg.solve(gram[..., 1:, 1:], gram[..., 1:, 0:1])[..., 0]
    c = np.concatenate([np.ones(a.shape[:-1] + (1,)), -a], axis=-1)
    fit = np.einsum("...i,...ij,...j->...", c, gram, c)
    held = np.einsum("...i,...ij,...j->...", c, score_gram, c)
    return fit, held


@dataclass
class OnsetGains:
    """Per candidate onset (rows of the grid) and training fold (columns): the in-fold
    statistic (choosing the onset) and the other fold's held-out statistic."""

    onsets: np.ndarray
    in_fold: np.ndarray      # (onsets, 2)
    held_out: np.ndarray     # (onsets, 2)


class RefittedNoise:
    """One output's one-step error ``e`` on the rows of two folds (weights ``folds``): scores
    candidate terms with the AR correction refitted for each, at every onset in ``onsets``."""

    def __init__(self, e: np.ndarray, folds: list[np.ndarray], onsets: np.ndarray, order: int = AR_ORDER):
        self.ze = lag_vectors(np.nan_to_num(e), order)
        self.folds = [np.asarray(w, float) for w in folds]
        self.onsets = np.asarray(onsets, int)
        self.rows = [float(w.sum()) for w in self.folds]
        self.gram = np.stack([self._gram(self.ze, w) for w in self.folds])
        self.nominal_fit, self.nominal_held = ar_errors(self.gram, self.gram[::-1])

    @staticmethod
    def _gram(z: np.ndarray, w: np.ndarray) -> np.ndarray:
        return (z * w[:, None]).T @ z

    def gains(self, psi: np.ndarray) -> OnsetGains:
        """The statistics of the candidate term ``psi`` (H^-1-filtered, on e's rows) switched on
        at each onset."""
        zp = lag_vectors(np.nan_to_num(psi), self.ze.shape[1] - 1)
        p1 = zp.shape[1]
        cross = zp[:, :, None] * zp[:, None, :] - self.ze[:, :, None] * zp[:, None, :]
        per_row = (cross + np.swapaxes(cross, 1, 2) - zp[:, :, None] * zp[:, None, :]).reshape(len(zp), -1)
        grams = []
        for w in self.folds:
            # suffix sums from each onset: block sums between grid onsets, accumulated backwards
            blocks = np.add.reduceat(per_row * w[:, None], self.onsets, axis=0)
            grams.append(np.cumsum(blocks[::-1], axis=0)[::-1].reshape(-1, p1, p1))
        m = np.stack(grams, axis=1) + self.gram[None]          # (onsets, fold, p1, p1)
        fit, held = ar_errors(m, m[:, ::-1])
        rows = np.array(self.rows)
        in_fold = rows * np.log(self.nominal_fit / fit)
        held_out = rows[::-1] * np.log(self.nominal_held / held)
        return OnsetGains(self.onsets, in_fold, held_out)
