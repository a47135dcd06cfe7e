"""PNG figures of a CompareResult for engineers: measured vs what the model predicts, the
correlations of the prediction error with their 99 % bands, and the fit over time with the
periods where the model fails shaded. Time axes are the data's own clock when it has
timestamps (``origin``), else hours since the first sample. Agg backend (no display)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .timeaxis import format_duration, plot_axis  # noqa: E402


def plot_compare(result, out_dir: Path, origin=None) -> list[Path]:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for oc in result.outputs:
        paths.append(plot_prediction(oc, out_dir / f"compare_{oc.output}_prediction.png", origin))
        paths.append(_correlations(oc, out_dir / f"compare_{oc.output}_residuals.png"))
        paths.append(_fit_over_time(oc, out_dir / f"compare_{oc.output}_fit_over_time.png", origin))
    return paths


def _shade_failing(ax, oc, convert, label: bool) -> None:
    for k, p in enumerate(oc.failing):
        ax.axvspan(convert(p.start_s), convert(p.end_s), color="tab:red", alpha=0.15, lw=0,
                   label="model fails here" if label and k == 0 else None)


def plot_prediction(oc, path: Path, origin=None) -> Path:
    """Measured output against the model's simulation and k-step prediction."""
    fig, ax = plt.subplots(figsize=(11, 4))
    t, xlabel, convert = plot_axis(oc.time_s, origin)
    ax.plot(t, oc.measured, color="0.3", lw=0.6, label="measured")
    ax.plot(t, oc.simulated, lw=0.8, label=f"model, from the inputs only (fit {oc.fit_simulation:.1f} %)")
    ax.plot(t, oc.predicted, lw=0.6,
            label=f"model, {oc.horizon} samples ahead (fit {oc.fit_prediction:.1f} %)")
    _shade_failing(ax, oc, convert, label=True)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(f"{oc.output}, about its mean")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"{oc.output}: measured and predicted by the model")
    ax.grid(alpha=0.3)
    return _save(fig, path)


def _correlations(oc, path: Path) -> Path:
    n = 1 + len(oc.cross)
    fig, axes = plt.subplots(n, 1, figsize=(8, 2.2 * n + 0.3), squeeze=False)
    panels = [(oc.whiteness, f"{oc.output}: prediction error vs its own past (should stay in the band)")]
    panels += [(c, f"{oc.output}: prediction error vs {c.column} (right of 0: {c.column} leads, a model error)")
               for c in oc.cross]
    for k, (ax, (c, title)) in enumerate(zip(axes[:, 0], panels)):
        lags, vals = np.array(c.lags), np.array(c.values)
        ax.bar(lags, vals, width=0.6, label="correlation")
        ax.axhspan(-c.bound, c.bound, color="tab:green", alpha=0.12, lw=0,
                   label="99 % band of a good model" if k == 0 else None)
        ax.set_title(title, fontsize=9, loc="left")
        ax.set_xlim(lags[0] - 1, lags[-1] + 1)
        ax.set_ylabel("correlation", fontsize=8)
        if k == 0:
            ax.legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("lag (samples)")
    return _save(fig, path)


def _fit_over_time(oc, path: Path, origin=None) -> Path:
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(11, 5.5), sharex=True)
    t, xlabel, convert = plot_axis(oc.window_start_s, origin,
                                   start_s=float(oc.time_s[0]) if oc.time_s is not None and len(oc.time_s) else None)
    ax.plot(t, oc.window_fit_simulation, ".-", label="model from the inputs only")
    ax.plot(t, oc.window_fit_prediction, ".-", label=f"model {oc.horizon} samples ahead")
    ax2.plot(t, oc.window_rms_error, ".-", color="k", label="one-step prediction error (RMS)")
    for a in (ax, ax2):
        _shade_failing(a, oc, convert, label=a is ax)
        a.grid(alpha=0.3)
    ax.set_ylabel("fit (%)")
    ax2.set_ylabel(f"{oc.output} error (RMS)")
    ax2.set_xlabel(f"window start, {xlabel}")
    if len(oc.window_start_s) > 1:
        width = format_duration(oc.window_start_s[1] - oc.window_start_s[0])
        ax.set_title(f"{oc.output}: how well the model fits, in moving windows (step {width})", loc="left")
    else:
        ax.set_title(f"{oc.output}: how well the model fits, in moving windows", loc="left")
    ax.legend(fontsize=8)
    ax2.legend(fontsize=8)
    return _save(fig, path)


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
