"""Figures of a diagnosis: per output, the model's one-step error with the findings' onsets."""
from __future__ import annotations

from pathlib import Path


def plot_residuals(result, out_dir) -> list[Path]:
    """``diagnose_<output>.png`` per output of ``result`` (a DiagnoseResult) in ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, e in result.residuals.items():
        fig, ax = plt.subplots(figsize=(11, 3.5))
        t = result.time_s / 3600.0
        ax.plot(t, e, lw=0.4, color="0.4", label="one-step error of the model")
        for f in result.findings:
            if f.output == name or (f.output is None and f.effect == "input_nonlinearity"):
                ax.axvline(f.onset_s / 3600.0, color="r", ls="--")
                ax.text(f.onset_s / 3600.0, ax.get_ylim()[1] * 0.9, f" {f.id} {f.effect}", color="r")
        ax.set_xlabel("time [h]")
        ax.set_ylabel(name)
        ax.set_title(f"{name}: one-step prediction error and findings")
        fig.tight_layout()
        path = out / f"diagnose_{name}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        paths.append(path)
    return paths
