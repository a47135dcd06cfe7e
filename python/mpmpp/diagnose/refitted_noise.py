"""Held-out gain of a candidate term in the one-step error when the AR noise correction is
refitted together with it, for every onset of a grid (the C++ ``_core.RefittedNoise``).

With e the one-step error of the nominal model (H^-1 (y - G u), its step + ramp disturbances
removed) and psi a candidate's H^-1-filtered contribution from onset k on, the candidate's error
is x_k = e - 1[t >= k] psi, and its AR(p) correction is refitted on x_k. Scoring a candidate
after whitening with the AR fitted to e instead penalises it when that AR has already absorbed
what the candidate explains (a limit cycle, an actuator's sticking phases): x_k is then less
predictable by the nominal AR than e is, though far more predictable by its own. The AR fitted
on one fold is scored on the other: the held-out statistic n log(SSE_nominal / SSE_candidate),
on the scale of a drop in the whitened squared error (a chi-square statistic).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _core
from .whitening import AR_ORDER


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
        self.onsets = np.asarray(onsets, int)
        self._core = _core.RefittedNoise(np.nan_to_num(e), np.asarray(folds[0], float),
                                         np.asarray(folds[1], float), self.onsets.tolist(), order)

    def gains(self, psi: np.ndarray) -> OnsetGains:
        """The statistics of the candidate term ``psi`` (H^-1-filtered, on e's rows) switched on
        at each onset."""
        g = self._core.gains(np.nan_to_num(psi))
        return OnsetGains(self.onsets, g.in_fold, g.held_out)
