"""The error a finding reports: the output's one-step prediction error with the nominal model
and with the model ``update`` writes, on held-out blocks after the onset."""
from __future__ import annotations

import numpy as np

from .. import _core
from ..signals import Signals, per_segment, valve_input
from .result import HeldOutError, ModelChange
from .whitening import OutputResidual


def one_step_errors(sig: Signals, i: int, changes: list[ModelChange]) -> np.ndarray:
    """One-step prediction errors of output i with the model after ``changes``."""
    name = sig.outputs[i]
    row = list(sig.rows[i])
    noise = sig.noise[i]
    extra_cols = []
    u = sig.u
    for c in changes:
        if c.output != name:
            continue
        if c.actuator is not None:
            j = sig.inputs.index(c.input)
            u = u.copy() if u is sig.u else u
            u[:, j] = valve_input(sig, j, c.actuator)
        if c.noise is not None:
            noise = c.noise
        if c.channel is not None:
            if c.new_input:
                extra_cols.append((c.channel, sig.z[:, sig.extras.index(c.input)]))
            else:
                row[sig.inputs.index(c.input)] = c.channel
    v = per_segment(sig, lambda yy, uu: _core.output_error(row, yy, uu), sig.y[:, i], u)
    for g, z in extra_cols:
        v = v - per_segment(sig, g.filter, np.nan_to_num(z))
        v[~np.isfinite(z)] = np.nan
    return per_segment(sig, lambda vv: noise.inverse().filter(np.nan_to_num(vv)), v) * np.where(np.isfinite(v), 1.0, np.nan)


def held_out_error(out: OutputResidual, onset: int, change: ModelChange) -> HeldOutError:
    """RMS one-step error on the odd blocks after onset: nominal model vs changed model."""
    test = out.fold[1].astype(bool) & (np.arange(len(out.e)) >= onset) & np.isfinite(out.e)
    after_e = one_step_errors(out.sig, out.i, [change])
    test &= np.isfinite(after_e)
    if not test.any():
        return HeldOutError(float("nan"), float("nan"))
    return HeldOutError(float(np.sqrt(np.mean(out.e[test] ** 2))), float(np.sqrt(np.mean(after_e[test] ** 2))))
