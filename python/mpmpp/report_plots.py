"""The figures only the report draws: the measured output against the model's prediction
before and after the update, the fall of the prediction error, and a one-glance timeline of
every channel's alarms. Each returns PNG bytes (the report embeds them)."""
from __future__ import annotations

import io

import numpy as np

from .detect import channel_label
from .timeaxis import format_duration, format_moment, plot_axis, shade_training

__all__ = ["png_bytes", "moving_rms", "plot_before_after", "plot_error_fall", "plot_alarm_timeline"]


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


def moving_rms(e, n: int) -> np.ndarray:
    """RMS of ``e`` over centred windows of ``n`` samples, missing values left out (NaN where
    fewer than half the window is present)."""
    e = np.asarray(e, dtype=float)
    ok = np.isfinite(e)
    kernel = np.ones(max(int(n), 1))
    total = np.convolve(np.where(ok, e * e, 0.0), kernel, "same")
    count = np.convolve(ok.astype(float), kernel, "same")
    return np.sqrt(np.divide(total, count, out=np.full_like(total, np.nan), where=count >= len(kernel) / 2))


def plot_before_after(output: str, time_s, measured, before, after, horizon: int, onsets=(), origin=None,
                      zoom_s: float = 3600.0, rms_s: float = 1800.0) -> bytes:
    """Top: a ``zoom_s`` stretch from the first finding's start (the end of the record when
    there is none) with the measured output and the k-step prediction of the model before and
    after the update. Bottom: the prediction error's moving RMS (``rms_s``) over the whole
    record, before and after. onsets: [(seconds, label)] of the findings applied."""
    plt = _pyplot()
    time_s = np.asarray(time_s, dtype=float)
    measured, before, after = (np.asarray(x, dtype=float) for x in (measured, before, after))
    ts = float(np.median(np.diff(time_s))) if len(time_s) > 1 else 1.0
    lo = min((s for s, _ in onsets), default=time_s[-1] - zoom_s)
    lo = min(max(lo, time_s[0]), max(time_s[-1] - zoom_s, time_s[0]))
    zoom = (time_s >= lo) & (time_s <= lo + zoom_s)
    fig, (ax, ax_e) = plt.subplots(2, 1, figsize=(11, 5.6), gridspec_kw={"height_ratios": [3, 2]})
    t, xlabel, convert = plot_axis(time_s, origin)
    ax.plot(t[zoom], measured[zoom], color="k", lw=0.8, label="measured")
    ax.plot(t[zoom], before[zoom], color="tab:orange", lw=1.1, label="model before the update")
    ax.plot(t[zoom], after[zoom], color="tab:blue", lw=1.1, label="model after the update")
    n = int(round(rms_s / ts))
    ax_e.plot(t, moving_rms(measured - before, n), color="tab:orange", lw=1.2, label="before the update")
    ax_e.plot(t, moving_rms(measured - after, n), color="tab:blue", lw=1.2, label="after the update")
    ax_e.axvspan(convert(lo), convert(min(lo + zoom_s, time_s[-1])), color="0.85", lw=0, label="stretch shown above")
    for k, (s, label) in enumerate(onsets):
        shown = [ax_e, ax] if lo <= s <= lo + zoom_s else [ax_e]
        for a in shown:
            a.axvline(convert(s), color="tab:red", ls="--", lw=1, label="finding starts" if k == 0 else None)
        ax_e.annotate(label, xy=(convert(s), 1.0), xycoords=("data", "axes fraction"), xytext=(3, -3),
                      textcoords="offset points", fontsize=8, color="tab:red", va="top")
    ax.set_title(f"{output}: measured and predicted {horizon} samples ahead, before and after the update "
                 f"({format_duration(zoom_s)} from {format_moment(lo, origin, float(time_s[0]))})", loc="left",
                 fontsize=9)
    ax.set_ylabel(f"{output}, about its mean")
    ax_e.set_title(f"prediction error, RMS over {format_duration(rms_s)}", loc="left", fontsize=9)
    ax_e.set_ylabel("error (RMS)")
    ax_e.set_xlabel(xlabel)
    ax.legend(fontsize=8, loc="lower left", ncol=4)
    ax_e.legend(fontsize=8, loc="upper left", ncol=4)
    for a in (ax, ax_e):
        a.grid(alpha=0.3)
    return png_bytes(fig)


def plot_error_fall(errors) -> bytes:
    """Bars of the held-out one-step prediction error before and after, per output."""
    plt = _pyplot()
    names = [e.output for e in errors]
    before = np.array([e.error_before for e in errors], dtype=float)
    after = np.array([e.error_after for e in errors], dtype=float)
    fig, ax = plt.subplots(figsize=(max(6.5, 1.6 * len(names) + 3.0), 3.4))
    x = np.arange(len(names))
    ax.bar(x - 0.2, before, 0.38, color="tab:orange", label="before the update")
    ax.bar(x + 0.2, after, 0.38, color="tab:blue", label="after the update")
    for k in range(len(names)):
        if before[k] > 0 and np.isfinite(after[k]):
            ax.annotate(f"{100 * (after[k] / before[k] - 1):+.0f} %", xy=(x[k] + 0.2, after[k]), xytext=(0, 3),
                        textcoords="offset points", ha="center", fontsize=8)
    ax.set_ylim(0, 1.15 * np.nanmax(np.r_[before, after, 0.0]) or 1.0)  # room for the labels
    ax.set_xticks(x, names)
    ax.set_ylabel("prediction error (RMS)")
    ax.set_title("Prediction error on held-out data,\nbefore and after the update", loc="left", fontsize=10)
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
    for row in range(len(result.channels)):
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
    ax.set_xlim(convert(start), t[-1] if len(t) else convert(start + 1))
    ax.set_yticks(np.arange(n) + 0.5, [channel_label(c) for c in reversed(result.channels)], fontsize=8)
    ax.set_xlabel(f"window end, {xlabel}")
    ax.set_title("Alarms per channel (G: process model, H: disturbance model)", loc="left", fontsize=10)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    ax.grid(alpha=0.3, axis="x")
    return png_bytes(fig)
