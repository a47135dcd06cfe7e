"""Spikes: additive outliers of a measured output (a transmitter glitch, a bad sample).

A spike s in y at t enters the one-step error e = H^-1 v as s h(k) at t + k, h the impulse
response of H^-1 (h(0) = 1, H monic). Left in, it biases every least-squares fit that sees
it, and in closed loop worst of all: the controller answers the spike, so its tail in e meets
the input's reaction to it, and a channel fitted to that pair reads the feedback as a process
change (held-out family mpc_3x3_move_limits, seed 644: outliers of 6 sigma on y2, five of them
found, made a dead time of 11 samples instead of 1 "throughout the record" at 0.77; simulated
without them, nothing).
The plant's true output did answer the controller's move, so taking s out of y at t (an
additive-outlier intervention) leaves exactly the record the plant made.
"""
from __future__ import annotations

import numpy as np

from .._core import TransferFunction
from ..signals import Signals
from .errors import one_step_errors
from .whitening import AR_ORDER, used_rows

SPIKE_SIGMAS = 5.0     # an innovation this many robust sigmas out is a spike candidate
MAX_SPIKE_SHARE = 0.1  # more than this: heavy tails, not spikes; nothing is taken out
SCALE_ROWS = 500       # rows per robust scale estimate: a disturbance whose level grows keeps its tails
ISOLATION = 3          # rows on either side of a spike that must be quiet once its tail is gone
QUIET_SIGMAS = 3.0     # quiet: within this many robust sigmas


def spike_sizes(e: np.ndarray, ok: np.ndarray, pieces: list[tuple[int, int]],
                hinv: TransferFunction) -> tuple[np.ndarray, np.ndarray]:
    """Rows and sizes of the spikes in the one-step error ``e`` (rows in ``ok``; ``pieces`` the
    [start, stop) ranges the filter H^-1 ran over). A candidate lies beyond SPIKE_SIGMAS robust
    sigmas (1.4826 MAD per SCALE_ROWS rows of its piece); its size is s = e(t) less the piece's
    median, and it is a spike when, its tail s h taken out, the ISOLATION rows before and after
    it are quiet (within QUIET_SIGMAS): a step of the output (a drift) or a process mismatch's
    answer to a move (a dead time or time constant off, seen a few rows after each setpoint
    step) raises its neighbours too, and is no spike. Candidates are taken in time order, each
    measured with the earlier spikes' tails gone."""
    rows, sizes, _ = _taken_out(e, ok, pieces, hinv)
    return rows, sizes


def without_spikes(e: np.ndarray, ok: np.ndarray, pieces: list[tuple[int, int]],
                   hinv: TransferFunction) -> np.ndarray:
    """``e`` with the tails of its spikes (``spike_sizes``) taken out."""
    return _taken_out(e, ok, pieces, hinv)[2]


def _taken_out(e: np.ndarray, ok: np.ndarray, pieces: list[tuple[int, int]],
               hinv: TransferFunction) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The spikes' rows and sizes (``spike_sizes``) and ``e`` with their tails taken out."""
    limit, centre = _limits(e, ok, pieces)
    # a spike is confirmed by the ISOLATION rows on either side: none at a piece's ends
    confirmable = np.zeros(len(e), bool)
    for a, b in pieces:
        confirmable[a + ISOLATION:max(b - ISOLATION, a)] = True
    candidates = np.flatnonzero(ok & confirmable & (np.abs(e - centre) > limit))
    if not len(candidates) or len(candidates) > MAX_SPIKE_SHARE * ok.sum():
        return np.zeros(0, int), np.zeros(0), e
    tail = _tail(hinv, len(e))
    cleaned = e.copy()
    rows, sizes = [], []
    for t in candidates:
        s = cleaned[t] - centre[t]
        if abs(s) <= limit[t]:
            continue   # made only by an earlier spike's tail, gone by now
        k = min(max(len(tail), 1 + ISOLATION), len(e) - t)
        trial = cleaned[t:t + k] - s * np.r_[tail, np.zeros(k)][:k]
        around = np.r_[cleaned[t - ISOLATION:t], trial[1:1 + ISOLATION]]
        near = np.r_[ok[t - ISOLATION:t], ok[t + 1:t + 1 + ISOLATION]]
        if np.any(near & (np.abs(around - centre[t]) > QUIET_SIGMAS / SPIKE_SIGMAS * limit[t])):
            continue
        cleaned[t:t + k] = trial
        rows.append(t)
        sizes.append(s)
    return np.asarray(rows, int), np.asarray(sizes, float), cleaned


def _tail(hinv: TransferFunction, n: int) -> np.ndarray:
    """The impulse response of H^-1 over at most n rows, cut where it falls below 1e-6 of its
    largest value."""
    tail = hinv.impulse(n)
    return tail[: max(int(np.flatnonzero(np.abs(tail) > 1e-6 * np.abs(tail).max()).max()) + 1, 1)]


def _limits(e: np.ndarray, ok: np.ndarray, pieces: list[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray]:
    """Per row: SPIKE_SIGMAS robust sigmas about the piece's median (infinite where nothing is
    known), the scale taken per SCALE_ROWS rows of the piece (the last stretch joined to the
    one before), the piece's own where a stretch has none."""
    limit = np.full(len(e), np.inf)
    centre = np.zeros(len(e))
    for a, b in pieces:
        x = e[a:b][ok[a:b]]
        if not len(x):
            continue
        centre[a:b] = np.median(x)
        whole = np.median(np.abs(x - centre[a]))
        edges = list(range(a, b, SCALE_ROWS))[: max((b - a) // SCALE_ROWS, 1)] + [b]
        for lo, hi in zip(edges[:-1], edges[1:]):
            xs = e[lo:hi][ok[lo:hi]]
            # a stretch with no spread of its own (a quantised or held signal) takes the piece's
            mad = np.median(np.abs(xs - centre[a])) if len(xs) else 0.0
            limit[lo:hi] = SPIKE_SIGMAS * 1.4826 * (mad if mad > 0.0 else whole)
    return limit, centre


def output_spikes(sig: Signals, i: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows and sizes of the spikes of output i in its one-step error under the model's channels
    and ``sig.noise[i]``, on the rows the fits use (``used_rows``)."""
    hinv = sig.noise[i].inverse()
    e = np.nan_to_num(one_step_errors(sig, i, []))
    return spike_sizes(e, used_rows(sig, i, hinv, AR_ORDER), list(sig.segments), hinv)
