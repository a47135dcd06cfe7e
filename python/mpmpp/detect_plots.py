"""Figures like the paper's Figs 3-8: profiles with event lines; SVM scores and indicator per
channel with the threshold."""
from __future__ import annotations

import numpy as np

from .clock import time_axis
from .detect import DetectionResult, channel_label

__all__ = ["plot_profiles", "plot_detection"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _events(ax, events):
    for t, _label in events or []:
        ax.axvline(t / 3600, color="r", linestyle="-.", linewidth=1)


def plot_profiles(model, data, path, events=None, title=None):
    """Outputs and inputs after removing their means, time in hours (Figs 3, 5, 6);
    events: [(seconds since the first sample, label)] drawn as red dash-dotted lines."""
    plt = _pyplot()
    names = list(model.outputs) + list(model.inputs)
    t = (data["time"].to_numpy(float) - float(data["time"].iloc[0])) / 3600
    fig, axes = plt.subplots(len(names), 1, figsize=(8, 1.8 * len(names)), sharex=True, squeeze=False)
    for ax, name in zip(axes[:, 0], names):
        x = data[name].to_numpy(float)
        ax.plot(t, x - np.nanmean(x), linewidth=0.6)
        ax.set_ylabel(("CV " if name in model.outputs else "MV ") + name, fontsize=8)
        _events(ax, events)
    axes[-1, 0].set_xlabel("time (h)")
    if title:
        axes[0, 0].set_title(title)
    if events:
        axes[0, 0].text(0.01, 0.95, "; ".join(f"{lbl} at {s / 3600:g} h" for s, lbl in events),
                        transform=axes[0, 0].transAxes, fontsize=7, va="top")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_detection(result: DetectionResult, path, kinds=("noise", "process"), events=None, title=None,
                   clock=None):
    """Per channel: the SVM scores (left) and the indicator with the threshold s_T (right),
    against the window end time (Figs 4, 7, 8); training windows score 0. With the data's
    ``clock`` (mpmpp.clock.Clock) the time axis is the data's own (dates for calendar time)."""
    plt = _pyplot()
    picked = [k for k, c in enumerate(result.channels) if c["kind"] in kinds]
    t0 = float(result.windows["start_s"].iloc[0]) if len(result.windows) else 0.0

    def axis(times):
        return time_axis(clock, times, t0, "window end (h)")

    t, xlabel = axis(result.windows["end_s"].to_numpy(float))
    fig, axes = plt.subplots(len(picked), 2, figsize=(10, 1.9 * len(picked) + 0.4), sharex=True, squeeze=False)
    for row, k in enumerate(picked):
        name = channel_label(result.channels[k])
        ax_s, ax_i = axes[row]
        s = result.scores[:, k]
        ax_s.plot(t, s, ".", markersize=2.5, color="tab:blue")
        ax_s.axhline(0, color="k", linewidth=0.5)
        # Channel names go in the panel titles: as y labels the long MIMO ones overlap.
        ax_s.set_title(f"{name}: SVM score h", fontsize=8, loc="left")
        ax_s.set_ylabel("score", fontsize=8)
        ax_i.plot(t, result.indicator[:, k], color="tab:green", linewidth=1)
        ax_i.axhline(result.threshold, color="r", linestyle="-.", linewidth=1)
        ax_i.set_ylim(-0.05, 1.05)
        ax_i.set_title(f"{name}: indicator s (eq. 23), threshold s_T", fontsize=8, loc="left")
        ax_i.set_ylabel("s", fontsize=8)
        for start in axis(result.alarm_starts(k))[0]:
            ax_i.axvline(start, color="k", linestyle=":", linewidth=1)
        _events(ax_s, events)
        _events(ax_i, events)
    for ax in axes[-1]:
        ax.set_xlabel(xlabel if clock is None else f"window end, {xlabel}")
    if clock is not None and clock.calendar:
        fig.autofmt_xdate()
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
