"""The error a finding reports: the output's one-step prediction error with the nominal model
and with the model ``update`` writes, on held-out blocks after the onset."""
from __future__ import annotations

import numpy as np

from ..signals import Signals, per_segment, valve_input
from .result import HeldOutError, ModelChange
from .whitening import OutputResidual, disturbance_drives, output_error


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
    v = output_error(sig, i, row, u)
    for g, z in extra_cols:
        v = v - per_segment(sig, g.filter, np.nan_to_num(z))
        v[~np.isfinite(z)] = np.nan
    return per_segment(sig, lambda vv: noise.inverse().filter(np.nan_to_num(vv)), v) * np.where(np.isfinite(v), 1.0, np.nan)


def held_out_error(out: OutputResidual, onset: int, change: ModelChange) -> HeldOutError:
    """RMS one-step error on the odd blocks after onset: nominal model vs changed model."""
    after_e = one_step_errors(out.sig, out.i, [change])
    test = _held_out_rows(out, onset, after_e)
    if not test.any():
        return HeldOutError(float("nan"), float("nan"))
    return HeldOutError(float(np.sqrt(np.mean(out.e[test] ** 2))), float(np.sqrt(np.mean(after_e[test] ** 2))))


def _held_out_rows(out: OutputResidual, onset: int, after_e: np.ndarray) -> np.ndarray:
    """The odd blocks' rows from ``onset`` on where both errors are known."""
    return out.fold[1].astype(bool) & (np.arange(len(out.e)) >= onset) & np.isfinite(out.e) & np.isfinite(after_e)


def held_out_error_beside(out: OutputResidual, onset: int, change: ModelChange, onsets: list[int]) -> HeldOutError:
    """``held_out_error`` with the output's step + ramp disturbances from ``onsets`` (and its
    level) fitted out of each one-step error first, by least squares on every usable row. No
    model update carries a disturbance, and one that sets in after the change's onset can
    outweigh what the update removes: mpc_siso_1s seed 15 (tuning), a time constant doubled
    at 9.0 h and a ramp disturbance from 10.8 h: the update (1.76x) raised the plain error after
    its onset 1.283 -> 1.299 and lowered it 1.009 -> 1.000 with the disturbances taken out."""
    drives = disturbance_drives(out, onsets)
    x = np.column_stack([per_segment(out.sig, out.noise.inverse().filter, d) for d in drives])
    after_e = one_step_errors(out.sig, out.i, [change])
    rows = (out.weight > 0) & np.isfinite(out.e) & np.isfinite(after_e)
    test = rows & _held_out_rows(out, onset, after_e)
    if not test.any():
        return HeldOutError(float("nan"), float("nan"))

    def rms(e):
        coef = np.linalg.lstsq(x[rows], e[rows], rcond=None)[0]
        return float(np.sqrt(np.mean((e[test] - x[test] @ coef) ** 2)))
    return HeldOutError(rms(out.e), rms(after_e))
