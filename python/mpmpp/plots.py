"""Figures like the paper's Figs 3, 5 and 6: CV and MV profiles minus their means, with a
vertical dash-dotted line at every scheduled change."""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd


def _figure():
    import matplotlib

    matplotlib.use("Agg")  # files only; never needs a display
    import matplotlib.pyplot as plt

    return plt


def _time_axis(time_s: np.ndarray):
    span = time_s[-1] - time_s[0] if len(time_s) > 1 else 0.0
    if span >= 5 * 3600:
        return time_s / 3600.0, "time (h)"
    return time_s / 60.0, "time (min)"


def plot_profiles(df: pd.DataFrame, columns: Sequence[str], path: str | Path,
                  event_times_s: Sequence[float] = (), title: str | None = None) -> Path:
    """One panel per column: the column minus its mean against time; events as red
    dash-dotted lines. Writes a PNG to `path` and returns it."""
    plt = _figure()
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise ValueError(f"plot: no column {missing[0]!r} in the data")
    t, label = _time_axis(df["time"].to_numpy(dtype=float))
    fig, axes = plt.subplots(len(columns), 1, sharex=True, figsize=(8, 1.9 * len(columns) + 0.6), squeeze=False)
    scale = 3600.0 if label == "time (h)" else 60.0
    for ax, col in zip(axes[:, 0], columns):
        v = df[col].to_numpy(dtype=float)
        ax.plot(t, v - np.nanmean(v), lw=0.5, color="tab:blue")
        for e in event_times_s:
            ax.axvline(e / scale, color="red", ls="-.", lw=1.0)
        ax.set_ylabel(col, fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel(label)
    if title:
        axes[0, 0].set_title(title)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def plot_simulation(df: pd.DataFrame, inputs: Sequence[str], outputs: Sequence[str], path: str | Path,
                    event_times_s: Sequence[float] = (), name: str = "") -> list[Path]:
    """The paper's figures for a simulation: one PNG with the CVs then the MVs (like Fig. 3)
    when there are at most two of each, else one PNG of outputs (Fig. 5) and one of inputs
    (Fig. 6), named <stem>_outputs.png and <stem>_inputs.png."""
    path = Path(path)
    if len(inputs) <= 2 and len(outputs) <= 2:
        return [plot_profiles(df, list(outputs) + list(inputs), path, event_times_s,
                              f"{name}: profiles minus means" if name else None)]
    stem = path.with_suffix("")
    return [plot_profiles(df, outputs, f"{stem}_outputs.png", event_times_s,
                          f"{name}: outputs minus means" if name else None),
            plot_profiles(df, inputs, f"{stem}_inputs.png", event_times_s,
                          f"{name}: inputs minus means" if name else None)]
