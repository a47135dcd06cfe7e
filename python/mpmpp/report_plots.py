"""The figures only the report draws: the measured output against the model's prediction
before and after the update, the fall of the prediction error, and a one-glance timeline of
every channel's alarms. Each returns PNG bytes (the report embeds them)."""
from __future__ import annotations

import io

import numpy as np

from .detect import channel_label
from .timeaxis import format_duration, format_moment, plot_axis, shade_training

__all__ = ["png_bytes", "plot_before_after", "plot_error_fall", "plot_alarm_timeline"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def png_bytes(fig, dpi: int = 90) -> bytes:
    plt = _pyplot()
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=dpi)
    plt.close(fig)
    return buf.getvalue()


def plot_before_after(output: str, time_s, measured, before, after, horizon: int, onsets=(), origin=None) -> bytes:
    """Measured output with the k-step prediction of the model before and after the update;
    onsets: [(seconds, label)] of the findings applied."""
    plt = _pyplot()
    fig, (ax, ax_e) = plt.subplots(2, 1, figsize=(11, 5.2), sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    t, xlabel, convert = plot_axis(time_s, origin)
    ax.plot(t, measured, color="0.35", lw=0.6, label="measured")
    ax.plot(t, before, color="tab:orange", lw=0.7, label="model before the update")
    ax.plot(t, after, color="tab:blue", lw=0.7, label="model after the update")
    ax_e.plot(t, np.asarray(measured) - np.asarray(before), color="tab:orange", lw=0.5, label="error before")
    ax_e.plot(t, np.asarray(measured) - np.asarray(after), color="tab:blue", lw=0.5, label="error after")
    for k, (s, label) in enumerate(onsets):
        for a in (ax, ax_e):
            a.axvline(convert(s), color="tab:red", ls="--", lw=1, label="finding starts" if k == 0 and a is ax else None)
        ax.annotate(label, xy=(convert(s), 1.0), xycoords=("data", "axes fraction"), xytext=(3, -3),
                    textcoords="offset points", fontsize=8, color="tab:red", va="top")
    ax.set_title(f"{output}: measured and predicted {horizon} samples ahead, before and after the update", loc="left",
                 fontsize=10)
    ax.set_ylabel(f"{output}, about its mean")
    ax_e.set_ylabel("prediction error")
    ax_e.set_xlabel(xlabel)
    ax.legend(fontsize=8, loc="lower left", ncol=4)
    ax_e.legend(fontsize=8, loc="lower left", ncol=2)
    for a in (ax, ax_e):
        a.grid(alpha=0.3)
    return png_bytes(fig)


def plot_error_fall(errors) -> bytes:
    """Bars of the held-out one-step prediction error before and after, per output."""
    plt = _pyplot()
    names = [e.output for e in errors]
    before = np.array([e.error_before for e in errors], dtype=float)
    after = np.array([e.error_after for e in errors], dtype=float)
    fig, ax = plt.subplots(figsize=(max(5.0, 1.6 * len(names) + 2.5), 3.4))
    x = np.arange(len(names))
    ax.bar(x - 0.2, before, 0.38, color="tab:orange", label="before the update")
    ax.bar(x + 0.2, after, 0.38, color="tab:blue", label="after the update")
    for k in range(len(names)):
        if before[k] > 0 and np.isfinite(after[k]):
            ax.annotate(f"{100 * (after[k] / before[k] - 1):+.0f} %", xy=(x[k] + 0.2, after[k]), xytext=(0, 3),
                        textcoords="offset points", ha="center", fontsize=8)
    ax.set_xticks(x, names)
    ax.set_ylabel("prediction error (RMS)")
    ax.set_title("One-step prediction error on held-out data after each finding's start", loc="left", fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    return png_bytes(fig)


def plot_alarm_timeline(result, origin=None) -> bytes:
    """One row per channel: training period shaded, time where the share of recent windows
    unlike training is at or above the threshold in red, alarm starts marked and labelled."""
    plt = _pyplot()
    n = len(result.channels)
    windows = result.windows
    start = float(windows["start_s"].iloc[0])
    end_s = windows["end_s"].to_numpy(float)
    t, xlabel, convert = plot_axis(end_s, origin, start_s=start)
    fig, ax = plt.subplots(figsize=(11, 0.45 * n + 1.4))
    shade_training(ax, start, start + result.train_end_s, convert)
    step = float(np.median(np.diff(end_s))) if len(end_s) > 1 else 0.0
    for row, c in enumerate(result.channels):
        y = n - 1 - row
        on = result.indicator[:, row] >= result.threshold
        for k in np.flatnonzero(on):
            ax.axvspan(convert(end_s[k] - step / 2), convert(end_s[k] + step / 2), ymin=(y + 0.2) / n,
                       ymax=(y + 0.8) / n, color="tab:red", alpha=0.5, lw=0)
        for s in result.alarm_starts(row):
            ax.plot([convert(s)], [y + 0.5], marker="v", color="tab:red", markersize=7)
            when = format_moment(s, origin)[:16] if origin is not None else format_duration(s - start)
            ax.annotate(when, xy=(convert(s), y + 0.5), xytext=(5, 2), textcoords="offset points", fontsize=7,
                        color="tab:red")
    ax.plot([], [], marker="v", color="tab:red", ls="none", label="alarm starts")
    ax.fill_between([], [], color="tab:red", alpha=0.5, label="alarm condition holds")
    ax.set_ylim(0, n)
    ax.set_xlim(t[0] if len(t) else 0, t[-1] if len(t) else 1)
    ax.set_yticks(np.arange(n) + 0.5, [channel_label(c) for c in reversed(result.channels)], fontsize=8)
    ax.set_xlabel(f"window end, {xlabel}")
    ax.set_title("Alarms per channel (G: process model, H: disturbance model)", loc="left", fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    ax.grid(alpha=0.3, axis="x")
    return png_bytes(fig)
