"""An orthonormal Laguerre basis of the inputs: a linear filter of the inputs expanded on few
functions (pole from the output's slowest channel), every function delayed one sample (no lag
0: in closed loop u(t) may already react to y(t)). It spans a channel change of any gain,
time constant or dead time near the model's with far fewer parameters than a FIR long enough
for slow channels."""
from __future__ import annotations

import math

import numpy as np

from .._core import TransferFunction, without_integrators
from ..integrating import row_integrates, without_line
from ..signals import Signals, filtered_columns, per_segment

LAGUERRE_FUNCTIONS = 8
DEFAULT_POLE = math.exp(-1.0 / 10.0)     # a 10-sample time constant when the output has no channel
# Samples an input basis starts before its channel's first lag: at shorter lags the input carries
# the controller's reaction to the disturbance (feedback), not the process (whitening.input_basis,
# actuator.linear_change_statistic).
BASIS_LEAD = 3


def laguerre_pole(sig: Signals, i: int) -> float:
    """The slowest real pole among output i's channels (0.5..0.99), an integrator's left out:
    the basis then spans the output's own dynamics with few functions."""
    poles = [abs(p) for g in sig.rows[i] if g is not None for p in np.asarray(without_integrators(g).poles())
             if 0.0 < abs(p) < 1.0]
    return float(np.clip(max(poles, default=DEFAULT_POLE), 0.5, 0.99))


def laguerre_filters(pole: float, count: int = LAGUERRE_FUNCTIONS) -> list[TransferFunction]:
    """L_k(q) = sqrt(1 - a^2) q^-1 / (1 - a q^-1) ((q^-1 - a) / (1 - a q^-1))^(k-1), k = 1..count."""
    first = TransferFunction([math.sqrt(1.0 - pole * pole)], [1.0, -pole], 1)
    all_pass = TransferFunction([-pole, 1.0], [1.0, -pole], 0)
    filters = [first]
    for _ in range(count - 1):
        filters.append(filters[-1].series(all_pass))
    return filters


def delayed_before(u: np.ndarray, lag: int) -> np.ndarray:
    """Input u delayed to BASIS_LEAD samples before a channel whose first lag is ``lag``
    (zeros shifted in; no delay for a channel that reacts within BASIS_LEAD samples)."""
    shift = max(int(lag) - BASIS_LEAD, 0)
    return np.r_[np.zeros(shift), u[: len(u) - shift]]


def basis_responses(sig: Signals, columns: np.ndarray, filters: list[TransferFunction]) -> np.ndarray:
    """Every column through every basis filter, per data segment (filters start at rest)."""
    return filtered_columns(sig, filters, np.nan_to_num(columns))


def output_basis(sig: Signals, i: int, columns: np.ndarray, filters: list[TransferFunction]) -> np.ndarray:
    """``basis_responses`` for output i. An output with an integrating channel changes inside its
    integrator (a level's valve gain, a lag of its flow), so each response is integrated too
    (summed from each segment's start, after the stable filter: folded into a high-order filter
    with poles near 1 the direct form overflows), and each segment's line is taken out of it,
    as it is out of the output error (whitening.output_error)."""
    x = basis_responses(sig, columns, filters)
    if not row_integrates(sig.rows[i]):
        return x
    return per_segment(sig, lambda xs: np.column_stack([without_line(np.cumsum(c)) for c in xs.T]), x)


def channel_basis(sig: Signals, i: int, j: int, lag: int) -> np.ndarray:
    """The basis of a change of output i's channel from input j, whose first lag is ``lag``:
    the input delayed to BASIS_LEAD samples before it, through the Laguerre filters on the
    output's slowest pole (``output_basis``). A gain, time-constant or dead-time change, or a
    mix, lies in its span."""
    delayed = delayed_before(np.nan_to_num(sig.u[:, j]), lag)
    return output_basis(sig, i, delayed[:, None], laguerre_filters(laguerre_pole(sig, i)))
