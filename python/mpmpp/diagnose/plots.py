"""Figures of a diagnosis: per output, the model's one-step error before and after each
finding's update on the same axes, with the findings' onsets."""
from __future__ import annotations

from pathlib import Path

import numpy as np

COLOURS = ("tab:blue", "tab:green", "tab:purple", "tab:orange")


def rolling_rms(x: np.ndarray, width: int) -> np.ndarray:
    """RMS over a centred window of ``width`` samples (NaN samples left out)."""
    ok = np.isfinite(x)
    kernel = np.ones(width)
    power = np.convolve(np.where(ok, x, 0.0) ** 2, kernel, mode="same")
    count = np.convolve(ok.astype(float), kernel, mode="same")
    return np.sqrt(np.divide(power, count, out=np.full(len(x), np.nan), where=count > width // 2))


def plot_residuals(result, out_dir, origin=None) -> list[Path]:
    """``diagnose_<output>.png`` per output of ``result`` (a DiagnoseResult) in ``out_dir``;
    ``origin``: the data's calendar origin (``mpmpp.timeaxis.origin_of``) for its own time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..timeaxis import plot_axis

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    t, xlabel, convert = plot_axis(result.time_s, origin)
    width = max(int(round(3600.0 / np.median(np.diff(result.time_s)))), 1) if len(t) > 1 else 1
    for name, e in result.residuals.items():
        fig, ax = plt.subplots(figsize=(11, 3.5))
        ax.plot(t, e, lw=0.4, color="0.6", label="one-step error, model")
        ax.plot(t, rolling_rms(e, width), lw=1.5, color="k", label="1 h RMS, model")
        mine = [f for f in result.findings if f.output == name]
        for f, colour in zip(mine, COLOURS):
            after = result.residuals_after.get(f.id)
            if after is not None:
                ax.plot(t, rolling_rms(after, width), lw=1.5, color=colour, label=f"1 h RMS, after {f.id}")
        for f in result.findings:
            if f.output == name or (f.output is None and f.effect == "input_nonlinearity"):
                onset = convert(f.onset_s)
                ax.axvline(onset, color="r", ls="--")
                ax.text(onset, ax.get_ylim()[1] * 0.9, f" {f.id} {f.effect}", color="r")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(name)
        ax.set_title(f"{name}: one-step prediction error before and after the findings' updates")
        ax.legend(loc="lower left", fontsize=7)
        fig.tight_layout()
        path = out / f"diagnose_{name}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths
