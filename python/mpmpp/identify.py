"""Closed-loop ARX-OE identification (paper Section 3) on NumPy arrays.

``arx`` is the high-order MISO ARX step, ``oe`` the output-error fit, ``arx_oe`` the
per-window pipeline (mean removal, ARX, A(q)-filtering, OE) and ``arx_oe_windows`` the
same over moving windows of a long series. The numerics are in C++ (``mpmpp._core``);
see docs/identification.md for conventions (nb counts coefficients, delays are known).
"""
from __future__ import annotations

import threading
from typing import Sequence, Union

import numpy as np

from . import _core

IntOrList = Union[int, Sequence[int]]

__all__ = ["arx", "oe", "arx_oe", "arx_oe_windows", "arx_oe_model", "channel_inputs", "channels",
           "fir_length_to_one_percent", "model_from_data"]  # noqa: F822 (module __getattr__)

fir_length_to_one_percent = _core.fir_length_to_one_percent


def _as_signals(y, u):
    y = np.asarray(y, dtype=float)
    u = np.asarray(u, dtype=float)
    if y.ndim != 1:
        raise ValueError(f"y must be 1-D (samples), got shape {y.shape}")
    if u.ndim == 1:
        u = u[:, None]
    if u.ndim != 2:
        raise ValueError(f"u must be 1-D or 2-D (samples x inputs), got shape {u.shape}")
    if u.shape[0] != y.shape[0]:
        raise ValueError(f"u must have {y.shape[0]} rows (the samples of y), got {u.shape[0]}")
    # Column-major so every input is one contiguous array for the C++ side (one copy).
    return y, np.asfortranarray(u)


def _per_input(value: IntOrList, m: int, name: str) -> list[int]:
    values = [int(value)] * m if np.isscalar(value) else [int(v) for v in value]
    if len(values) != m:
        raise ValueError(f"{name} must have one entry per input ({m}), got {len(values)}")
    return values


def channels(delays: IntOrList, structure: str = "foptd", nb: IntOrList = 1,
             nf: IntOrList = 1, m: int | None = None) -> list:
    """OE structures per input: 'foptd' (b q^-d / (1 + f q^-1)), 'oe' (nb, nf) or
    'fir' (nb taps from q^-d on)."""
    m = len(delays) if m is None and not np.isscalar(delays) else (m or 1)
    d = _per_input(delays, m, "delays")
    if structure == "foptd":
        return [_core.OeChannel.foptd(dj) for dj in d]
    if structure == "oe":
        return [_core.OeChannel(b, f, dj) for b, f, dj in
                zip(_per_input(nb, m, "nb"), _per_input(nf, m, "nf"), d)]
    if structure == "fir":
        return [_core.OeChannel.fir(b, dj) for b, dj in zip(_per_input(nb, m, "nb"), d)]
    raise ValueError(f"structure must be 'foptd', 'oe' or 'fir', got {structure!r}")


def arx(y, u, na: int, nb: IntOrList, delays: IntOrList, *, delta: float = 1e-4,
        rank_tolerance: float = 1e-10, stretch_starts=()):
    """High-order ARX  A(q) y = sum_j q^-d_j B_j(q) u_j + e  by (regularised) least squares.

    nb counts the coefficients of each B_j (paper's order n = 9: na=9, nb=10). Returns
    an ``ArxResult`` (a, b, theta, covariance, noise_variance, equations, regularised).
    The data are used as given (no mean removal). ``stretch_starts``: rows where a new
    complete stretch begins (a record with gaps, laid end to end); no lag reaches across."""
    y, u = _as_signals(y, u)
    m = u.shape[1]
    return _core.arx(y, u, int(na), _per_input(nb, m, "nb"), _per_input(delays, m, "delays"),
                     delta=delta, rank_tolerance=rank_tolerance, stretch_starts=list(stretch_starts))


def oe(y, u, delays: IntOrList, structure: str = "foptd", nb: IntOrList = 1,
       nf: IntOrList = 1, *, skip: int = 0, max_iterations: int = 200,
       max_pole_radius: float = 0.9999, init_fir_length: int = 0, stretch_starts=()):
    """Output-error fit of all channels of one output jointly (criterion over t >= skip,
    zero initial state; with ``stretch_starts``, of every stretch from its start at rest,
    over its rows from ``skip`` on). Returns an ``OeResult`` (b, f, theta, covariance, cost, ...)."""
    y, u = _as_signals(y, u)
    chans = channels(delays, structure, nb, nf, m=u.shape[1])
    return _core.oe(y, u, chans, skip=skip, max_iterations=max_iterations,
                    max_pole_radius=max_pole_radius, init_fir_length=init_fir_length,
                    stretch_starts=list(stretch_starts))


# Per thread: estimate() releases the GIL and an estimator's workspace is not shareable.
_estimators = threading.local()


def _estimator(m, na, nb, delays, structure, oe_nb, oe_nf, fir_length, detrend, delta,
               max_iterations, max_pole_radius, two_step_covariance):
    """The ArxOeEstimator of these settings, reused by later calls with the same settings
    in the same thread: building one through pybind11 costs ~10 us (~7% of a 1,440-sample
    window) and its C++ workspace is then allocated once, not per call."""
    key = (m, na, nb, delays, structure, oe_nb, oe_nf, fir_length, detrend, delta,
           max_iterations, max_pole_radius, two_step_covariance)
    try:
        hash(key)
    except TypeError:  # per-input lists
        key = tuple(tuple(a) if isinstance(a, (list, np.ndarray)) else a for a in key)
    cache = _estimators.__dict__.setdefault("by_settings", {})
    try:
        return cache[key]
    except (KeyError, TypeError):  # TypeError: still unhashable, left to the C++ checks
        pass
    est = _core.ArxOeEstimator(
        int(na), _per_input(nb, m, "nb"), _per_input(delays, m, "delays"),
        channels(delays, structure, oe_nb, oe_nf, m=m), _per_input(fir_length, m, "fir_length"),
        detrend=detrend, delta=delta, max_iterations=max_iterations,
        max_pole_radius=max_pole_radius, two_step_covariance=bool(two_step_covariance))
    if len(cache) >= 16:  # a few settings in practice; bound the memory anyway
        cache.clear()
    try:
        cache[key] = est
    except TypeError:
        pass
    return est


def arx_oe(y, u, na: int, nb: IntOrList, delays: IntOrList, *, structure: str = "foptd",
           oe_nb: IntOrList = 1, oe_nf: IntOrList = 1, fir_length: IntOrList = 60,
           detrend: str = "mean", delta: float = 1e-4, max_iterations: int = 200,
           max_pole_radius: float = 0.9999, two_step_covariance: bool = False, stretch_starts=()):
    """ARX-OE estimate of one output from one window (or from the complete stretches of a
    record laid end to end, each new one starting at a row of ``stretch_starts``: every filter
    starts at rest in each): detrend ('none', 'mean', 'linear'),
    ARX(na, nb, delays), filter by A(q), OE of the given structure. Returns an
    ``ArxOeResult``: channels[j] (b, f, delay, fir, gain), noise (a_1..a_na), arx, oe, and
    with ``two_step_covariance`` (FIR structure only) the covariance of oe.theta that
    includes the ARX step's A(q) uncertainty. RuntimeError when the window is not
    informative."""
    y, u = _as_signals(y, u)
    est = _estimator(u.shape[1], na, nb, delays, structure, oe_nb, oe_nf, fir_length, detrend,
                     delta, max_iterations, max_pole_radius, two_step_covariance)
    return est.estimate(y, u, list(stretch_starts))


def arx_oe_windows(y, u, window: int, step: int, na: int, nb: IntOrList, delays: IntOrList,
                   **options):
    """``arx_oe`` on the windows [s, s + window), s = 0, step, ..., of a long series.
    Returns a list of ``WindowEstimate`` (start, ok, message, result); a window that is
    not informative (missing samples, constant input, ...) has ok=False and the reason."""
    y, u = _as_signals(y, u)
    defaults = dict(structure="foptd", oe_nb=1, oe_nf=1, fir_length=60, detrend="mean",
                    delta=1e-4, max_iterations=200, max_pole_radius=0.9999, two_step_covariance=False)
    unknown = set(options) - set(defaults)
    if unknown:
        raise ValueError(f"unknown option(s) for arx_oe_windows: {sorted(unknown)}")
    defaults.update(options)
    est = _estimator(u.shape[1], na, nb, delays, defaults["structure"], defaults["oe_nb"],
                     defaults["oe_nf"], defaults["fir_length"], defaults["detrend"],
                     defaults["delta"], defaults["max_iterations"], defaults["max_pole_radius"],
                     defaults["two_step_covariance"])
    return est.estimate_windows(y, u, int(window), int(step))


def channel_inputs(model, output: str) -> list[str]:
    """The inputs that have a channel to ``output`` in ``model``, in the model's order:
    the column order of every estimate ``arx_oe_model`` returns for that output."""
    if output not in model.outputs:
        raise ValueError(f"output {output!r} is not in the model (outputs: {list(model.outputs)})")
    return [name for name in model.inputs if model.process(output, name) is not None]


def arx_oe_model(model, data, output: str, *, na: int = 9, nb: IntOrList | None = None,
                 structure: str = "nominal", fir_length: IntOrList | None = None,
                 window: int | None = None, step: int | None = None, detrend: str = "mean",
                 delta: float = 1e-4, two_step_covariance: bool = False):
    """ARX-OE of one output of a model + data pair (MISO over the inputs the model
    connects to it, delays from the nominal channels).

    model: a ``Model`` or a model file path; data: a DataFrame (``load_data``,
    ``simulate``) or a data file path. structure: 'nominal' (each G_j with the nominal
    channel's numerator/denominator orders: the paper's correctly parameterised case),
    'foptd' or 'fir' (fir_length taps). nb: ARX numerator coefficients per input
    (default na + 1, the paper's equal orders). fir_length: impulse-response length per
    channel (default: until the nominal response falls below 1% of its peak).
    Without ``window`` one estimate from the whole record (an ``ArxOeResult``); with
    ``window`` and ``step`` (samples) a list of ``WindowEstimate``. An input with a valve in
    the model's actuators block enters as its simulated valve position (the channel is the
    linear part behind the valve, docs/stiction.md "Model file").
    """
    from .io import load_data, load_model
    from .signals import through_actuators

    if not hasattr(model, "process"):
        model = load_model(model)
    if not hasattr(data, "columns"):
        data = load_data(data, model)
    inputs = channel_inputs(model, output)
    if not inputs:
        raise ValueError(f"output {output!r} has no process channel in the model")
    for name in inputs + [output]:
        if name not in data.columns:
            raise ValueError(f"data has no column {name!r}")
    nominal = [model.process(output, name) for name in inputs]
    delays = [g.delay for g in nominal]
    lengths = ([fir_length_to_one_percent(g) for g in nominal] if fir_length is None
               else _per_input(fir_length, len(inputs), "fir_length"))
    if structure == "nominal":
        structure, oe_nb, oe_nf = "oe", [len(g.num) for g in nominal], [len(g.den) - 1 for g in nominal]
    elif structure == "fir":  # taps from the delay on, covering the impulse-response length
        oe_nb, oe_nf = [max(1, L - d) for L, d in zip(lengths, delays)], 0
    else:
        oe_nb, oe_nf = 1, 1
    y = data[output].to_numpy(dtype=float)
    u = through_actuators(model, data[inputs].to_numpy(dtype=float), inputs=inputs)
    options = dict(structure=structure, oe_nb=oe_nb, oe_nf=oe_nf, fir_length=lengths,
                   detrend=detrend, delta=delta, two_step_covariance=two_step_covariance)
    nb = na + 1 if nb is None else nb
    if window is None:
        return arx_oe(y, u, na, nb, delays, **options)
    if step is None:
        raise ValueError("step is required with window")
    return arx_oe_windows(y, u, window, step, na, nb, delays, **options)


def __getattr__(name):
    # model_from_data (a whole model file from data) lives in model_identification, which
    # builds on this module: imported on first use.
    if name in ("model_from_data", "NotIdentified"):
        from . import model_identification

        return getattr(model_identification, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
