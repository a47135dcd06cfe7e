"""compare's valve check: does a hysteresis of an input explain the one-step error beyond
every linear explanation? A sticking or slack valve is what a linear channel cannot hold, so a
model identified on the record (or tuned to it) leaves compare's linear residual tests clean
while the valve is there (issue 18: compare flagged the OP's cross-correlation on 1 of 33
stiction records and on 21 of 44 others).

The plant sees the valve position p = f(u) instead of the OP u. Under backlash of width w
(Prandtl's play operator) p - u stays within +-w/2 and follows the direction of the last move;
a weighted sum of play operators of several widths (the Prandtl-Ishlinskii model) approximates
any rate-independent hysteresis, the sticking phases of stick-slip included. With the model's
channel G and noise model H, the one-step error then holds z_w = H^-1 G (p_w - u) for the widths
present. The test regresses e on the linear explanations (ERROR_LAGS lags of e itself, the
colour a missing or wrong noise model leaves; the input's Laguerre basis whitened by H^-1, a
gain, time-constant or dead-time error on every time scale) and on the z_w of WIDTHS. The drop of the residual sum of squares the z_w add,
N (RSS_lin - RSS_full) / RSS_full, is asymptotically chi-square(len(WIDTHS)) when the valve is
linear: z_w(t) reads u up to t - 1 only (shifted when the channel has a lag-0 term), and in closed
loop the past of u carries no part of the innovation e(t) beyond e's own past. A flag also needs
the plays to explain MIN_SHARE of what the linear explanations leave: on a long record a linear
change with an onset inside it, which no fit over the whole record holds, leaves a misfit the
plays take a little of, significant but small. (The Billings-Voon correlation tests check a
model against nonlinearities in general; this one asks the physical question of a valve.)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .integrating import row_integrates, without_line
from .signals import Signals, filtered_columns, per_segment, valve_positions

# Play widths in multiples of the input's spread (its standard deviation over the record): a
# valve's dead zone is a fraction of the OP's travel in the record. Widths, level, share and
# error lags chosen on the stiction study's TUNING loops, seeds 7001-7004, and on six tuning
# scenario families, seeds 0-4 (studies/compare_hysteresis.py, docs/stiction.md "compare's
# hysteresis check"): 0.1-1.6 in octaves flagged 15 of 31 sticking valves and none of 62 linear
# loops at 1e-3 (four widths 0.1-1: 13 and 1). Without the error's own lags 6 of 10 no-change
# family records were flagged (no noise model: e is coloured); without the Laguerre basis and
# the share 15 of 20 gain changes (with both none: a change inside the record leaves a misfit of
# which the plays take 0.2-2.7 %, of a sticking valve's error they take 3-25 %).
WIDTHS = (0.1, 0.2, 0.4, 0.8, 1.6)
SIGNIFICANCE = 1e-3
MIN_SHARE = 0.03
ERROR_LAGS = 10


@dataclass
class HysteresisCheck:
    """The hysteresis test of one modelled channel."""

    column: str
    explained: float        # share of what the linear explanations leave that the plays explain
    statistic: float        # N (RSS_lin - RSS_full) / RSS_full
    width: float            # the play width whose direction alone explains most (input units)
    significant: bool       # statistic above the chi-square(len(WIDTHS)) quantile at SIGNIFICANCE
                            # and explained >= MIN_SHARE


def hysteresis_check(sig: Signals, i: int, j: int, err: np.ndarray, valid: np.ndarray) -> HysteresisCheck | None:
    """The test for output i's channel from input j; ``err``: the output's one-step error as
    compare takes it, ``valid``: its usable rows. None when the channel is not modelled, the
    input does not move, too few rows remain or the error is zero or overflows."""
    from scipy.special import chdtri   # the chi-square quantile (scipy.stats costs 0.7 s to import)

    row, name = sig.rows[i], sig.inputs[j]
    if row[j] is None:
        return None
    spread = float(np.nanstd(sig.u[:, j]))
    if not spread > 0.0:
        return None
    widths = spread * np.asarray(WIDTHS)
    z = _play_directions(sig, i, j, widths)
    basis = _linear_change_basis(sig, i, j)
    rows = np.flatnonzero(valid & np.all(np.isfinite(z), axis=1) & np.all(np.isfinite(basis), axis=1))
    rows = rows[rows >= ERROR_LAGS]
    rows = rows[np.all(valid[rows[:, None] - np.arange(1, ERROR_LAGS + 1)], axis=1)]
    columns = 1 + ERROR_LAGS + basis.shape[1] + len(widths)
    if len(rows) <= 2 * columns:
        return None
    # one Gram matrix of [level, lags of e, the whitened Laguerre basis, plays], columns scaled
    # to unit norm; every nested least-squares fit is a solve on its block (a QR of the design
    # per fit cost 2 s more on a week of 3x3 data; the test checks these against it)
    own = err[rows[:, None] - np.arange(1, ERROR_LAGS + 1)]
    phi = np.column_stack([np.ones(len(rows)), own, basis[rows], z[rows]])
    norms = np.linalg.norm(phi, axis=0)
    phi /= np.where(norms > 0, norms, 1.0)
    e = err[rows]
    gram, cross, total = phi.T @ phi, phi.T @ e, float(e @ e)
    if not (np.all(np.isfinite(gram)) and np.all(np.isfinite(cross)) and total > 0.0):
        return None   # an error that overflows or vanishes: nothing to judge

    def rss(cols) -> float:
        c = cross[cols]
        return total - float(c @ np.linalg.lstsq(gram[np.ix_(cols, cols)], c, rcond=None)[0])

    linear = list(range(columns - len(widths)))
    lin, full = rss(linear), rss(list(range(columns)))
    statistic = float(len(rows) * (lin - full) / full) if full > 0 else 0.0
    alone = [rss(linear + [len(linear) + k]) for k in range(len(widths))]
    explained = (lin - full) / lin if lin > 0 else 0.0
    return HysteresisCheck(column=name, explained=explained, statistic=statistic,
                           width=float(widths[int(np.argmin(alone))]),
                           significant=bool(statistic > chdtri(len(widths), SIGNIFICANCE)
                                            and explained >= MIN_SHARE))


def _linear_change_basis(sig: Signals, i: int, j: int) -> np.ndarray:
    """H^-1 applied to the channel's Laguerre basis (``laguerre.channel_basis``): a gain,
    time-constant or dead-time error of the channel lies in its span on every time scale with a
    few functions. A wide play, nearly a valve that stopped moving, looks like a lower gain;
    beside this basis it counts only for what no linear change explains."""
    from .diagnose.laguerre import channel_basis
    from .diagnose.process import first_lag

    row, hinv = sig.rows[i], sig.noise[i].inverse()
    basis = channel_basis(sig, i, j, first_lag(row[j]))
    white = filtered_columns(sig, [hinv], basis)
    return per_segment(sig, lambda b: np.column_stack([without_line(c) for c in b.T]), white) \
        if row_integrates(row) else white


def _play_directions(sig: Signals, i: int, j: int, widths) -> np.ndarray:
    """One column per width w: z_w = e(y, u) - e(y, u with input j through a play of width w)
    = H^-1 G (p_w - u), per segment (the play starts at rest at each segment's first row),
    taken as compare takes the error of an integrating output (each segment's line removed);
    one sample later when the channel has a lag-0 term, so that z_w(t) never reads u(t)."""
    from .diagnose.process import first_lag   # (diagnose imports compare)

    row, noise = sig.rows[i], sig.noise[i]
    zero = np.zeros(len(sig.time_s))

    def error(u):
        e = per_segment(sig, lambda uu, yy: _core.prediction_error(row, noise, yy, uu), u, zero)
        return per_segment(sig, without_line, e) if row_integrates(row) else e

    nominal = error(sig.u)
    columns = []
    for width in widths:
        moved = sig.u.copy()
        moved[:, j] = valve_positions(sig, j, {"kind": "backlash", "S": width}) - sig.operating_point[sig.inputs[j]]
        columns.append(nominal - error(moved))
    z = np.column_stack(columns)
    if first_lag(row[j]) == 0:
        z = np.vstack([np.full((1, z.shape[1]), np.nan), z[:-1]])
    return z
