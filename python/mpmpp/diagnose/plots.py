"""Figures of a diagnosis: per output, the model's one-step error before and after each
finding's update on the same axes, with the findings' onsets, and below it the output's process
part (the input-explained part of y - G u) before and after, where a right fix shows. A channel
change's onset set (the onsets the data fit as well) is shaded around its onset line."""
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
        mine = [f for f in result.findings if f.output == name]
        parts = [(f, result.process_parts[f.id]) for f in mine if f.id in result.process_parts]
        fig, axes = plt.subplots(2 if parts else 1, 1, figsize=(11, 6.5 if parts else 3.5), sharex=True,
                                 squeeze=False)
        ax = axes[0, 0]
        ax.plot(t, e, lw=0.4, color="0.6", label="one-step error, model")
        ax.plot(t, rolling_rms(e, width), lw=1.5, color="k", label="1 h RMS, model")
        for f, colour in zip(mine, COLOURS):
            after = result.residuals_after.get(f.id)
            if after is not None:
                ax.plot(t, rolling_rms(after, width), lw=1.5, color=colour, label=f"1 h RMS, after {f.id}")
        for f in result.findings:
            if f.output == name or (f.output is None and f.effect == "input_nonlinearity"):
                onset = convert(f.onset_s)
                ax.axvline(onset, color="r", ls="--")
                if f.onset_earliest_s is not None and f.onset_latest_s > f.onset_earliest_s:
                    # the onsets the data cannot tell from this one (the finding's onset set)
                    ax.axvspan(convert(f.onset_earliest_s), convert(f.onset_latest_s), color="r", alpha=0.12, lw=0)
                ax.text(onset, ax.get_ylim()[1] * 0.9, f" {f.id} {f.effect}", color="r")
        ax.set_ylabel(name)
        ax.set_title(f"{name}: one-step prediction error before and after the findings' updates")
        ax.legend(loc="lower left", fontsize=7)
        if parts:
            _plot_process_parts(axes[1, 0], t, parts, name)
        axes[-1, 0].set_xlabel(xlabel)
        fig.tight_layout()
        path = out / f"diagnose_{name}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths


def _plot_process_parts(ax, t, parts, name) -> None:
    """The process part after each finding's onset: nominal model (black) and updated model."""
    before = parts[0][1][0]
    ax.plot(t, before, lw=0.8, color="k", label=f"model (held-out RMS {parts[0][0].process_error_before:.3g})")
    for (f, (_, after)), colour in zip(parts, COLOURS):
        ax.plot(t, after, lw=0.8, color=colour, label=f"after {f.id} (held-out RMS {f.process_error_after:.3g})")
    ax.axhline(0.0, color="0.6", lw=0.5)
    ax.set_ylabel(f"{name}, process part")
    ax.set_title("input-explained part of y - G u (fitted on the even 1 h blocks after the onset)")
    ax.legend(loc="lower left", fontsize=7)
