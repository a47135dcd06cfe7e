"""The disturbance model behind detection: the ARX order must cover it.

The closed-loop ARX step of every window (paper eq. 12) stands in for 1/H_i with A_i(q) of
order n_a. When n_a is shorter than 1/H_i's impulse response, the ARX residual is coloured and
the process estimates of a closed loop are biased. So the order ``detect`` uses is at least the
disturbance model's AR order:

* an output whose model file gives H_i: the taps of 1/H_i's impulse response down to 1 % of
  its first tap (the rule the FIR length uses for G, ``fir_length_to_one_percent``);
* an output without one (H_i = 1 in the file, the normal case for hand-written models): H_i is
  estimated from the training rows as 1/A(q), A the least-squares AR(p) of the output error
  v = y_i - G_i u (``_core.fit_ar``) less its unmeasured step and ramp disturbances (an AR
  would read them as a random walk). The model equals the plant in training, so v is the
  disturbance itself, not a closed-loop estimate. p is chosen by BIC (Schwarz): AR(p) of a
  finite ARMA is only an approximation, and AIC's lighter penalty keeps adding coefficients
  on thousands of rows, each a feature of the noise channel that its SVM must then learn.

Both are capped at ``MAX_ORDER`` and at one coefficient per ``WINDOW_ROWS_PER_COEFFICIENT``
window samples, so a 2 h window at 60 s keeps the preset's order.

The residual process test whitens each window's output error by an AR(p) refitted in the window
(residual_regression.hpp). There p must not exceed what the disturbance needs: in closed loop
without excitation a process change is predictable from the output error's own past, and an
AR(18) absorbs most of it (docs/detection.md "The whitening order"). So every output, with or
without a noise model in the file, also gets ``whitening``: the BIC order of its training
output error (the model file's H is a claim; the training rows are the disturbance itself).
``detect`` whitens by at least ``WHITENING_FLOOR`` coefficients: a disturbance that changes
colour after training (a noise change) needs some room, or the colour left in the whitened
error biases beta and passes for a process change.

A wandering disturbance (nearly integrated, IMA(1,1)-like: H = (1 - c q^-1) / (1 - a q^-1), a
near 1, as most plants' are) needs a far longer AR than that; the whitening then also carries a
moving-average root c (``whitening_root``), chosen with the order by BIC on the same training
rows (the MA_ROOTS grid identify uses). Each window passes its output error and directions
through 1 / (1 - c q^-1) before its AR fit (residual_regression.hpp). c is fixed by the
training, so unlike a longer AR refitted per window it cannot absorb a change.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _core
from .diagnose.whitening import TREND_GRID, disturbance_steps, has_noise_model
from .model_identification import MA_ROOTS
from .signals import complete_runs

MAX_ORDER = 30
WINDOW_ROWS_PER_COEFFICIENT = 24
IMPULSE_TOLERANCE = 0.01
# Chosen on the tuning families (docs/detection.md "The whitening order"): the BIC order alone
# (often 0-1) let 25 of 210 forced noise changes raise an MPM alarm, at least 3 let 7 (the
# AR(18) before: 4), at least 4 the same 7 with 2 fewer detections.
WHITENING_FLOOR = 3


@dataclass
class DisturbanceOrder:
    """The AR order of one output's disturbance model and where it came from."""

    output: str
    order: int
    estimated: bool                 # True: fitted to the training rows (no noise model in the file)
    polynomial: np.ndarray = None   # A(q) = [1, a_1, ..., a_p] of the estimate; None when not estimable
    rows: int = 0                   # rows the estimate used (or had)
    # The residual test's whitening (every output): the BIC order of the training output error
    # less its mean, through 1 / (1 - c q^-1) for the moving-average root c chosen with it
    # (``whitening_root``); None when not estimable.
    whitening: int | None = None
    whitening_root: float = 0.0


def inverse_order(h, cap: int) -> int:
    """Taps k >= 1 of 1/H's impulse response until it stays below 1 % of its first tap (at most cap)."""
    taps = np.abs(np.asarray(h.inverse().impulse(cap + 1), dtype=float).ravel())
    above = np.flatnonzero(taps[1:] >= IMPULSE_TOLERANCE * taps[0])
    return int(above[-1]) + 1 if above.size else 0


def bic_ar(v: np.ndarray, begin: int, end: int, max_order: int) -> tuple[int, np.ndarray, float, int]:
    """(p, A, BIC, N) minimising N log s2_p + p log N over p = 0..max_order, every order fitted
    on the same N rows of [begin, end): those whose v(t - max_order) .. v(t) are all present (v
    is NaN where it is not known: a lost sample, a stretch's start-up), so begin >= max_order."""
    present = np.isfinite(v)
    missing = np.concatenate([[0], np.cumsum(~present)])
    t = np.arange(begin, end)
    rows = t[missing[t + 1] == missing[t - max_order]]
    n = len(rows)
    s2 = np.asarray(_core.ar_residual_variances(v, max_order, begin, end), dtype=float).ravel()
    bic = n * np.log(s2) + np.arange(max_order + 1) * math.log(n)
    p = int(np.argmin(bic))
    poly = np.asarray(_core.fit_ar(v, p, begin, end, max_order), dtype=float).ravel() if p else np.array([1.0])
    return p, poly, float(bic[p]), n


def _settling_samples(row, length: int) -> int:
    """Samples until every channel's impulse response has fallen below 1 % of its peak: the
    output error is filtered from rest, so its first samples are not the disturbance yet. An
    integrating channel's is its stable part's (``_core.without_integrators``): from there on
    the inputs before the stretch leave a constant, which the level fitted beside takes."""
    settle = 0
    for g in row:
        if g is None:
            continue
        h = np.abs(np.asarray(_core.without_integrators(g).impulse(length), dtype=float).ravel())
        above = np.flatnonzero(h >= IMPULSE_TOLERANCE * h.max()) if h.max() > 0 else np.array([0])
        settle = max(settle, int(above[-1]) + 1)
    return settle


def whitening_root(w: np.ndarray, begin: int, end: int, cap: int) -> tuple[float, int]:
    """(c, p): the moving-average root of MA_ROOTS and the AR order that minimise the BIC of w
    (an output error less its steps and ramps; NaN where unknown) less its mean, through
    1 / (1 - c q^-1), charged one coefficient for c > 0. The mean goes first because each
    window fits its own level (residual_regression.hpp): left in, the filter's gain 1 / (1 - c)
    on it let a root near 1 win on a white disturbance (tuning mpc_level seed 19). A monic
    causal filter keeps the Gaussian likelihood's scale, and NaNs stay where they were, so the
    roots compete on the same rows."""
    w = w - np.nanmean(w[begin:end])
    best = None
    for c in MA_ROOTS:
        p, _, bic, n = bic_ar(_through_root(w, c) if c else w, begin, end, cap)
        bic += math.log(n) if c else 0.0
        if best is None or bic < best[0]:
            best = (bic, c, p)
    return best[1], best[2]


def _through_root(w: np.ndarray, c: float) -> np.ndarray:
    """w through 1 / (1 - c q^-1) from rest at every run of known samples (NaN stays NaN; a run's
    first samples miss the earlier ones' trail, which the thousands of rows after it outweigh)."""
    known = np.isfinite(w)
    starts = [a for a, _ in complete_runs(known)]
    out = np.asarray(_core.TransferFunction(np.ones(1), np.array([1.0, -c]), 0).filter(
        np.where(known, w, 0.0), stretch_starts=starts), dtype=float).ravel()
    out[~known] = np.nan
    return out


def _training_error_ar(model, i: int, train: np.ndarray, u: np.ndarray, y: np.ndarray, cap: int):
    """(p, A, rows, c, p_c): the BIC-chosen AR of output i's error y_i - G_i u, less its step and
    ramp disturbances, on every complete stretch of the training rows (each filtered from rest,
    its first rows, G's settling time plus the largest order, left out of the fit) in the rows'
    time, and the moving-average root with its AR order (``whitening_root``); (None, None,
    rows, 0.0, None) when fewer than 10 rows per coefficient remain."""
    name = model.outputs[i]
    row = [model.process(name, j) for j in model.inputs]
    used = [j for j, g in enumerate(row) if g is not None]
    ok = train & np.isfinite(y[:, i]) & np.isfinite(u[:, used]).all(axis=1)
    runs = complete_runs(ok)
    if not runs:
        return None, None, 0, 0.0, None
    first, last = runs[0][0], runs[-1][1]
    # Deviations from the training operating point; G filters them from rest at each stretch's
    # first row, so v is unknown (NaN) until G has settled.
    u0, y0 = u[ok].mean(axis=0), y[ok, i].mean()
    v = np.full(last - first, np.nan)
    fitted = np.zeros(last - first, bool)
    for a, b in runs:
        settle = _settling_samples(row, b - a)
        if b - a <= settle + cap:
            continue
        du, dy = u[a:b] - u0, y[a:b, i] - y0
        v[a + settle - first:b - first] = np.asarray(
            _core.output_error(row, np.ascontiguousarray(dy), np.asfortranarray(du)), dtype=float).ravel()[settle:]
        fitted[a + settle + cap - first:b - first] = True
    rows = int(fitted.sum())
    if rows < 10 * cap:
        return None, None, rows, 0.0, None
    begin = int(np.argmax(fitted))
    # Unmeasured step and ramp disturbances out first: an AR takes them for a random walk and
    # BIC then asks for 15-30 coefficients (tuning mpc_siso_1s, mpc_siso_disturbed), which
    # absorb process changes as surely as the ARX order did; the windows' own fits take them
    # as breaks (residual_regression.hpp).
    _, steps = disturbance_steps(np.where(fitted, v, 0.0), fitted, _core.TransferFunction(), begin, TREND_GRID,
                                 begin + TREND_GRID, math.log(rows))
    order, poly, _, _ = bic_ar(v - steps, begin, last - first, cap)
    # The root is chosen on the error less its steps: filtered, a step or ramp grows into a
    # random walk that the step search then reads differently for every root.
    root, root_order = whitening_root(v - steps, begin, last - first, cap)
    return order, poly, rows, root, root_order


def disturbance_orders(model, time_s: np.ndarray, u: np.ndarray, y: np.ndarray, train_end_s: float,
                       window_samples: int, whitening: bool = True) -> list[DisturbanceOrder]:
    """Per output, the AR order of its disturbance model: from the model file's H, or estimated
    (BIC) on the complete stretches of the training rows; order 0 without a polynomial
    when fewer than 10 rows per coefficient remain after settling. With ``whitening`` (the
    residual test's orders are wanted) every output gets the estimate's order, else only those
    the estimate is made for."""
    cap = max(1, min(MAX_ORDER, window_samples // WINDOW_ROWS_PER_COEFFICIENT))
    train = (time_s - time_s[0]) < train_end_s
    out = []
    for i, name in enumerate(model.outputs):
        h = model.noise(name)
        if has_noise_model(h) and not whitening:
            out.append(DisturbanceOrder(name, inverse_order(h, cap), estimated=False))
            continue
        order, poly, rows, root, root_order = _training_error_ar(model, i, train, u, y, cap)
        if has_noise_model(h):
            out.append(DisturbanceOrder(name, inverse_order(h, cap), estimated=False, rows=rows, whitening=root_order,
                                        whitening_root=root))
        else:  # the estimate; too short to estimate: order 0, the preset's order stands and the note says why
            out.append(DisturbanceOrder(name, order or 0, estimated=True, polynomial=poly, rows=rows,
                                        whitening=root_order, whitening_root=root))
    return out


def describe(d: DisturbanceOrder, arx_order: int, whitening: int | None = None) -> str:
    """One note line for an output without a noise model; ``whitening``: the residual test's
    AR order for it (None: the ARX step's order n_a is the one that matters)."""
    if d.polynomial is None:
        used = (f"the residual test whitens each window by the config's AR({whitening})" if whitening is not None
                else f"the ARX order n_a = {arx_order} of the config stands")
        return (f"{d.output}: the model has no noise model, and the training period leaves {d.rows} complete "
                f"rows after the process settles, too few to estimate one; {used}")
    root = f" after 1/(1 - {d.whitening_root:g} q^-1) (a wandering disturbance)" if d.whitening_root else ""
    used = (f"the residual test whitens each window by an AR({whitening}){root}" if whitening is not None
            else f"the ARX order n_a = {arx_order} covers it")
    return (f"{d.output}: the model has no noise model; its disturbance model was estimated from "
            f"{d.rows} training rows as H = 1/A(q), A the BIC-chosen AR({d.order}) of y - G u less its steps "
            f"and ramps; {used}")
