"""PNG figures of a CompareResult: measured vs predicted, residual correlations with their
99 % bands, fit over time. Uses the non-interactive Agg backend (no display needed)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .clock import time_axis  # noqa: E402


def plot_compare(result, out_dir: Path, clock=None) -> list[Path]:
    """With the data's ``clock`` (mpmpp.clock.Clock) time axes are the data's own time."""
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for oc in result.outputs:
        paths.append(_measured_vs_predicted(oc, out_dir / f"compare_{oc.output}_prediction.png", clock))
        paths.append(_correlations(oc, out_dir / f"compare_{oc.output}_residuals.png"))
        paths.append(_fit_over_time(oc, out_dir / f"compare_{oc.output}_fit_over_time.png", clock))
    return paths


def _measured_vs_predicted(oc, path: Path, clock) -> Path:
    fig, ax = plt.subplots(figsize=(11, 4))
    t, xlabel = time_axis(clock, oc.time_s, label="time [h]")
    ax.plot(t, oc.measured, color="0.3", lw=0.6, label="measured")
    ax.plot(t, oc.simulated, lw=0.8, label=f"simulated (fit {oc.fit_simulation:.1f} %)")
    ax.plot(t, oc.predicted, lw=0.6, label=f"{oc.horizon}-step prediction (fit {oc.fit_prediction:.1f} %)")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(f"{oc.output} (deviation)")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"{oc.output}: measured vs model")
    return _save(fig, path)


def _correlations(oc, path: Path) -> Path:
    n = 1 + len(oc.cross)
    fig, axes = plt.subplots(n, 1, figsize=(8, 2.2 * n), squeeze=False)
    panels = [(oc.whiteness, "autocorrelation of the one-step error")]
    panels += [(c, f"cross-correlation error vs {c.column} (negative lags: feedback)") for c in oc.cross]
    for ax, (c, title) in zip(axes[:, 0], panels):
        lags, vals = np.array(c.lags), np.array(c.values)
        ax.bar(lags, vals, width=0.6)
        ax.axhline(c.bound, color="r", ls="--", lw=0.8)
        ax.axhline(-c.bound, color="r", ls="--", lw=0.8)
        ax.set_title(title, fontsize=9)
        ax.set_xlim(lags[0] - 1, lags[-1] + 1)
    axes[-1, 0].set_xlabel("lag [samples]")
    return _save(fig, path)


def _fit_over_time(oc, path: Path, clock) -> Path:
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(11, 5.5), sharex=True)
    t, xlabel = time_axis(clock, oc.window_start_s, label="window start [h]")
    ax.plot(t, oc.window_fit_simulation, ".-", label="simulation")
    ax.plot(t, oc.window_fit_prediction, ".-", label=f"{oc.horizon}-step prediction")
    ax2.plot(t, oc.window_rms_error, ".-", color="k")
    for a in (ax, ax2):
        for p in oc.failing:
            start, end = time_axis(clock, [p.start_s, p.end_s])[0]
            a.axvspan(start, end, color="r", alpha=0.15)
    ax.set_ylabel("fit [%]")
    ax2.set_ylabel("one-step error RMS")
    ax2.set_xlabel(xlabel if clock is None else f"window start, {xlabel}")
    ax.set_title(f"{oc.output}: fit in moving windows (red: where it fails)")
    ax.legend(fontsize=8)
    return _save(fig, path)


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
