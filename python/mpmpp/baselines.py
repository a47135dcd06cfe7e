"""Baseline monitors the paper argues against (Sec. 1), on the detector's own windows.

Both watch one index per output and cannot say which input's channel changed, nor whether
the process or the disturbance did; an alarm is therefore an "MPM alarm" on every process
channel of that output. They share the detector's alarm rule (eq. 23 over the same n_T
windows, alarm at s >= s_T), with "index above its limit" in place of a negative SVM score:

* ``variance``: output-variance ratio, var(y_i) over the window divided by its mean over the
  training windows (a historical-data benchmark, like the MV/Harris index it is blind to the
  cause of a variance change). Limit 1.5: variance up by half.
* ``residual``: prediction-error variance ratio of the nominal model,
  eps_i = H_i^-1 (y_i - sum_j G_ij u_j) on deviations from the training means, windowed
  variance over its training mean; with the right model and noise model eps is the white
  innovation, so a ratio above the limit (1.5) says the model no longer predicts the data.
"""
from __future__ import annotations

import numpy as np

from . import _core

__all__ = ["BASELINES", "baseline_indices", "baseline_alarms"]

BASELINES = {"variance": 1.5, "residual": 1.5}  # name -> limit on the index


def _window_variance(x: np.ndarray, first: np.ndarray, length: int) -> np.ndarray:
    """Variance of x over [f, f + length) for every window start f (NaN if the window has NaN)."""
    c1 = np.concatenate([[0.0], np.cumsum(x)])
    c2 = np.concatenate([[0.0], np.cumsum(x * x)])
    s1 = c1[first + length] - c1[first]
    s2 = c2[first + length] - c2[first]
    return (s2 - s1 * s1 / length) / (length - 1)


def baseline_indices(model, time_s, u, y, windows_first, window_samples, training_mask):
    """{name: windows x outputs array} of both indices."""
    first = np.asarray(windows_first, dtype=int)
    training = np.asarray(training_mask, dtype=bool)
    ref = slice(0, int(first[training].max() + window_samples)) if training.any() else slice(0, len(y))
    out = {"variance": np.empty((first.size, y.shape[1])), "residual": np.empty((first.size, y.shape[1]))}
    for i in range(y.shape[1]):
        var_y = _window_variance(y[:, i], first, window_samples)
        out["variance"][:, i] = var_y / np.nanmean(var_y[training])
        # Deviations from the training means (the operating point); NaN samples are zeroed for
        # the filters and the windows holding them are set NaN below.
        dy = np.nan_to_num(y[:, i] - np.nanmean(y[ref, i]))
        pred = np.zeros(len(dy))
        for j, name in enumerate(model.inputs):
            g = model.process(model.outputs[i], name)
            if g is not None:
                du = np.nan_to_num(u[:, j] - np.nanmean(u[ref, j]))
                pred += np.asarray(g.filter(du))
        eps = np.asarray(model.noise(model.outputs[i]).inverse().filter(dy - pred))
        var_e = _window_variance(eps, first, window_samples)
        out["residual"][:, i] = var_e / np.nanmean(var_e[training])
    bad = np.array([not (np.isfinite(u[f:f + window_samples]).all() and np.isfinite(y[f:f + window_samples]).all())
                    for f in first])
    for v in out.values():
        v[bad] = np.nan
        v[training] = 1.0  # like the SVM scores: no verdict inside the training period
    return out


def baseline_alarms(indices: dict, end_s, n_T: int, alarm_count: int) -> dict:
    """{name: {output index: [alarm start times]}} under the detector's alarm rule."""
    end_s = np.asarray(end_s, dtype=float)
    alarms = {}
    for name, index in indices.items():
        limit = BASELINES[name]
        alarms[name] = {}
        for i in range(index.shape[1]):
            ind = _core.MismatchIndicator(n_T, alarm_count)
            starts = []
            for w, v in enumerate(index[:, i]):
                # "negative" = index above its limit; NaN (skipped window) counts as not.
                _, _, started = ind.push(limit - v if np.isfinite(v) else float("nan"))
                if started:
                    starts.append(float(end_s[w]))
            alarms[name][i] = starts
    return alarms
