"""Is a change of the one-step error after an onset a change of the disturbance, or of the process?

Two model structures compete for the one-step error e = H^-1 (y - G u) after the onset, each
fitted on one fold's blocks and scored on the other's (held-out Gaussian log-likelihood):

* disturbance change: A(q) e = c + w, a new noise colour and level (what ``noise_change``
  writes);
* process change: A(q) e = c + sum_j B_j(q) H^-1 u_j + w, the same plus a linear filter of every
  model input (the output's Laguerre basis, diagnose/process_error.py; every function delays by
  a sample, so the controller's reaction to y(t) within the sample is not fitted).

Fitted jointly, the AR part whitens the new disturbance, and the innovation w(t) of a pure
disturbance change is then uncorrelated with the inputs' past even in closed loop (the
controller only sees past outputs): the input filter gains nothing on held-out data beyond
estimation noise. When the process changed instead, (G_true - G) u is in e and only the input
filter predicts it. The residual tests of ``compare`` cannot separate the two (a wrong noise
model makes e coloured and the controller then correlates it with the inputs); this joint fit
can. It is the direct prediction-error method's consistency condition turned into a test.
The disturbance side holds a moving-average root beside its AR (``root_ar``, chosen on the fold
that fits), and both structures see e and the inputs through it: a wandering disturbance whose
colour changed leaves e nearly differenced after the onset, which no AR of this order whitens,
and the colour left was what the inputs, a filter of e's past under feedback, then predicted.
"""
from __future__ import annotations

import math

import numpy as np

from ..signals import filtered_columns
from .laguerre import laguerre_filters, laguerre_pole, output_basis
from .whitening import NOISE_ORDER, OutputResidual, correction, filter_pieces, root_ar


def input_driven_gain(out: OutputResidual, folds: list[np.ndarray], order: int = NOISE_ORDER) -> tuple[float, int]:
    """(held-out log-likelihood gain, parameters): the process-change structure over the
    disturbance-change structure on e after the onset. ``folds``: the two folds' rows after the
    onset. Gain = sum over both folds of n_test log(var_AR / var_ARX), each fitted on the other
    fold; parameters = the input filter's coefficients."""
    sig = out.sig
    e = np.nan_to_num(out.e)
    hinv = out.noise.inverse()
    whitened_u = filtered_columns(sig, [hinv], np.nan_to_num(sig.u))
    x = np.nan_to_num(output_basis(sig, out.i, whitened_u, laguerre_filters(laguerre_pole(sig, out.i))))
    whole = [(0, len(e))]
    roots = out.offered_roots
    gain = 0.0
    for k in (0, 1):
        fit, test = folds[k], folds[1 - k]
        c = root_ar(e, whole, fit, None, roots, order)[0] if len(roots) > 1 else 0.0   # (0,): nothing to choose
        through = correction(np.ones(1), c)
        both = _design(through.filter(e), filter_pieces(through, x, whole), order) if c else _design(e, x, order)
        target = both[:, 0]
        var = []
        for z in (both[:, 1:2 + order], both[:, 1:]):  # the disturbance side is the first columns
            coef = np.linalg.lstsq(z[fit], target[fit], rcond=None)[0]
            var.append(float(np.mean((target[test] - z[test] @ coef) ** 2)))
        gain += int(test.sum()) * math.log(var[0] / var[1]) if var[1] > 0 else 0.0
    return gain, x.shape[1]


def _design(e: np.ndarray, x: np.ndarray, order: int) -> np.ndarray:
    """[e, 1, e lagged 1..order, x], column-major."""
    both = np.zeros((len(e), 2 + order + x.shape[1]), order="F")
    both[:, 0] = e
    both[:, 1] = 1.0
    for k in range(1, order + 1):
        both[k:, 1 + k] = e[:-k]
    both[:, 2 + order:] = x
    return both
