"""Figures of a detection for engineers (the paper's Figs 3-8 in plain words): signal profiles
with the known events, and per channel how unlike the training period each window looks and
how many recent windows did, with the alarm threshold, the training period shaded and the
alarms marked with their times. Time axes are the data's own clock when it has timestamps
(``origin``), else hours (or minutes) since the first sample."""
from __future__ import annotations

import textwrap

import numpy as np

from .detect import DetectionResult
from .timeaxis import format_duration, format_moment, mark_alarms, plot_axis, shade_training

__all__ = ["plot_profiles", "plot_detection"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _channel_title(channel: dict) -> str:
    if channel["kind"] == "noise":
        return f"{channel['output']}: disturbance (noise model)"
    if channel.get("in_model") is False:
        return f"{channel['output']} \u2190 {channel['input']} (not in the model)"
    return f"{channel['output']} \u2190 {channel['input']} (process model)"


def _event_lines(ax, events, convert, numbered: bool = False):
    for k, (t, _label) in enumerate(events or [], start=1):
        x = convert(t)
        ax.axvline(x, color="tab:purple", linestyle="-.", linewidth=1,
                   label="known change" if k == 1 else None)
        if numbered:
            ax.annotate(str(k), xy=(x, 1.0), xycoords=("data", "axes fraction"), xytext=(2, -2),
                        textcoords="offset points", fontsize=8, color="tab:purple", va="top")


def _events_caption(events, origin, t0) -> str:
    """'1: noise model of y changed at 9 h 35 min; 2: ...' wrapped to the figure's width."""
    when = (lambda s: format_moment(s, origin)) if origin is not None else (lambda s: format_duration(s - t0))
    text = "; ".join(f"{k}: {label} at {when(s)}" for k, (s, label) in enumerate(events, start=1))
    return "\n".join(textwrap.wrap("Known changes: " + text, 120))


def plot_profiles(model, data, path, events=None, title=None, origin=None):
    """Outputs (controlled variables) and inputs (manipulated variables) about their means
    against time (Figs 3, 5, 6); events: [(seconds in the data's time, label)] drawn as
    numbered dash-dotted lines and listed under the figure."""
    plt = _pyplot()
    names = list(model.outputs) + list(model.inputs)
    time_s = data["time"].to_numpy(float)
    t, xlabel, convert = plot_axis(time_s, origin)
    fig, axes = plt.subplots(len(names), 1, figsize=(9, 1.7 * len(names) + 1.0), sharex=True, squeeze=False)
    for ax, name in zip(axes[:, 0], names):
        x = data[name].to_numpy(float)
        ax.plot(t, x - np.nanmean(x), linewidth=0.5, color="tab:blue")
        role = "controlled variable (output)" if name in model.outputs else "manipulated variable (input)"
        ax.set_title(f"{name}: {role}, minus its mean {np.nanmean(x):.4g}", fontsize=8, loc="left")
        ax.set_ylabel(name, fontsize=8)
        ax.grid(alpha=0.3)
        _event_lines(ax, events, convert, numbered=ax is axes[0, 0])
    axes[-1, 0].set_xlabel(xlabel)
    if title:
        fig.suptitle(title, fontsize=10)
    if events:
        fig.text(0.01, 0.005, _events_caption(events, origin, float(time_s[0])), fontsize=7, va="bottom")
    caption_lines = _events_caption(events, origin, float(time_s[0])).count("\n") + 1 if events else 0
    fig.tight_layout(rect=(0, (0.2 + 0.16 * caption_lines) / fig.get_figheight(), 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_detection(result: DetectionResult, path, kinds=("noise", "process"), events=None, title=None, origin=None):
    """Per channel, against the end time of each moving window: left, how far the window's
    identified model lies inside (> 0) or outside (< 0) the region learnt in training (the
    one-class SVM score, eq. 20; for a residual-test process channel log10(p / level) of its
    Wald test, negative when p < level); right, the share of the recent windows that were outside
    (the indicator, eq. 23) with the alarm threshold. Training windows score 0."""
    plt = _pyplot()
    picked = [k for k, c in enumerate(result.channels) if c["kind"] in kinds]
    if not picked:
        raise ValueError(f"plot_detection: no channel of kind {', '.join(kinds)}")
    windows = result.windows
    start = float(windows["start_s"].iloc[0]) if len(windows) else 0.0
    t, xlabel, convert = plot_axis(windows["end_s"].to_numpy(float), origin, start_s=start)
    train_end = start + result.train_end_s
    fig, axes = plt.subplots(len(picked), 2, figsize=(11, 2.1 * len(picked) + 0.9), sharex=True, squeeze=False)
    for row, k in enumerate(picked):
        ax_s, ax_i = axes[row]
        name = _channel_title(result.channels[k])
        s = result.scores[:, k]
        for ax in (ax_s, ax_i):
            shade_training(ax, start, train_end, convert, label=row == 0)
            ax.grid(alpha=0.3)
        # Training windows score 0 by construction: not drawn.
        monitored = ~windows["training"].to_numpy(bool)
        outside = monitored & (s < 0)
        inside = monitored & ~(s < 0)
        ax_s.plot(t[inside], s[inside], ".", markersize=2.5, color="tab:blue",
                  label="window like training" if row == 0 else None)
        ax_s.plot(t[outside], s[outside], ".", markersize=3, color="tab:orange",
                  label="window unlike training" if row == 0 else None)
        ax_s.axhline(0, color="k", linewidth=0.6)
        ax_s.set_title(f"{name}: similarity to training", fontsize=8, loc="left")
        ax_s.set_ylabel("score (< 0: unlike)", fontsize=8)
        ax_i.plot(t, 100 * result.indicator[:, k], color="tab:green", linewidth=1.2,
                  label="recent windows unlike training" if row == 0 else None)
        ax_i.axhline(100 * result.threshold, color="tab:red", linestyle="--", linewidth=1,
                     label=f"alarm threshold ({100 * result.threshold:g} %)" if row == 0 else None)
        ax_i.set_ylim(-5, 125)  # headroom for the alarm labels
        ax_i.set_yticks([0, 25, 50, 75, 100])
        ax_i.set_title(f"{name}: recent windows unlike training", fontsize=8, loc="left")
        ax_i.set_ylabel("% of last windows", fontsize=8)
        mark_alarms(ax_i, result.alarm_starts(k), convert, origin=origin, start_s=start)
        _event_lines(ax_s, events, convert)
        _event_lines(ax_i, events, convert)
    for ax in axes[-1]:
        ax.set_xlabel(f"window end, {xlabel}")
    handles, labels = [], []
    for ax in axes.ravel():
        for h, lbl in zip(*ax.get_legend_handles_labels()):
            if lbl not in labels:
                handles.append(h)
                labels.append(lbl)
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 4), fontsize=8, frameon=False)
    if title:
        fig.suptitle(title, fontsize=10)
    legend_rows = -(-len(labels) // 4)
    top = 1 - (0.3 / fig.get_figheight() if title else 0)  # the suptitle above the first row's titles
    fig.tight_layout(rect=(0, (0.1 + 0.22 * legend_rows) / fig.get_figheight(), 1, top))
    fig.savefig(path, dpi=110)
    plt.close(fig)
