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
        folds = [np.asarray(w, float) for w in folds]
        self.onsets = np.asarray(onsets, int)
        self.rows = np.array([w.sum() for w in folds])
        self.gram = np.stack([(self.ze * w[:, None]).T @ self.ze for w in folds])
        self.nominal_fit, self.nominal_held = ar_errors(self.gram, self.gram[::-1])
        # Row blocks that lie in one fold and between two grid onsets: the suffix sums are
        # block sums, accumulated backwards per fold.
        self.weight = folds[0] + folds[1]
        label = np.where(folds[0] > 0, 0, np.where(folds[1] > 0, 1, -1))
        changes = np.flatnonzero(np.diff(label)) + 1
        self.starts = np.unique(np.r_[self.onsets, changes[changes > self.onsets[0]]])
        self.block_fold = label[self.starts]
        self.block_onset = np.searchsorted(self.onsets, self.starts, side="right") - 1

    def gains(self, psi: np.ndarray) -> OnsetGains:
        """The statistics of the candidate term ``psi`` (H^-1-filtered, on e's rows) switched on
        at each onset."""
        zp = lag_vectors(np.nan_to_num(psi), self.ze.shape[1] - 1)
        p1 = zp.shape[1]
        # z^p z^p' - z^e z^p' - z^p z^e' is the symmetric part of (z^p - 2 z^e) z^p'
        per_row = ((zp - 2.0 * self.ze) * self.weight[:, None])[:, :, None] * zp[:, None, :]
        blocks = np.add.reduceat(per_row.reshape(len(zp), -1), self.starts, axis=0)
        m = np.zeros((len(self.onsets), 2, p1 * p1))
        keep = self.block_fold >= 0
        np.add.at(m, (self.block_onset[keep], self.block_fold[keep]), blocks[keep])
        m = np.cumsum(m[::-1], axis=0)[::-1].reshape(len(self.onsets), 2, p1, p1)
        m = 0.5 * (m + np.swapaxes(m, 2, 3)) + self.gram[None]          # (onsets, fold, p1, p1)
        fit, held = ar_errors(m, m[:, ::-1])
        in_fold = self.rows * np.log(self.nominal_fit / fit)
        held_out = self.rows[::-1] * np.log(self.nominal_held / held)
        return OnsetGains(self.onsets, in_fold, held_out)
