"""Bias and spread of ``mpmpp identify`` on simulated PI loops, against the true model and an
independent reference.

Loops: flow / level-like / pressure-like first order plus dead time (tests/python/pi_loop.py, a
plain NumPy PI-loop simulator), 2 h at 10 s (751 rows), routine operation (disturbances only)
and with setpoint steps. Per loop and seed, ``model_from_data`` gives gain K, time constant tau
and dead time theta with their reported uncertainty. The reference re-fits the selected
structure (the same na, delay, numerator length) with SciPy's least_squares on the joint
prediction-error criterion, all parameters at once (tests/python/identification_reference.py,
written from the equations), and converts it with its own ZOH inversion. Columns: bias and spread (sd over seeds) in % of the true value for K
and tau, in seconds for theta; "cover" is the share of seeds whose 95 % interval holds the
truth; seeds refused as "not identified" are counted and left out of the statistics; "flagged
uncertain" counts identified seeds whose summary warns that the model is loosely determined.

    PYTHONPATH=python python studies/identify_study.py --seeds 20
"""
from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))

import identification_reference as ref  # noqa: E402
import pi_loop  # noqa: E402

from mpmpp.model_identification import NotIdentified, model_from_data  # noqa: E402


def reference_foptd(y, u, na, delay, nb, ts):
    """SciPy's joint prediction-error fit of the given structure, then K, tau, theta by the ZOH
    inverse."""
    b, f, _ = ref.pem_ar_noise(y, u, na, nb, delay)
    a = -f[1]
    gain = b.sum() / (1 - a)
    tau = -ts / np.log(a) if 0 < a < 1 else 0.0
    frac = 0.0
    if nb == 2 and 0 < a < 1:
        frac = 1 - np.log(a + (1 - a) * b[1] / b.sum()) / np.log(a)
    return gain, tau, (delay - 1 + frac) * ts


def run_case(loop, steps, seeds, ts=10.0, rows=751):
    est, refs, covered, refused, uncertain = [], [], [], 0, 0
    truth = np.array([loop.gain, loop.time_constant_s, loop.dead_time_s])
    for seed in seeds:
        df = pi_loop.simulate(loop, seed, rows=rows, ts=ts, setpoint_steps=steps)
        try:
            r = model_from_data(df, ["OP"], ["PV"])
        except NotIdentified:
            refused += 1
            continue
        c = r.channels[0]
        uncertain += c.uncertain
        est.append([c.gain, c.time_constant_s, c.dead_time_s])
        lo = [c.gain - 1.96 * c.gain_sd, c.time_constant_s - 1.96 * c.time_constant_sd, c.dead_time_ci95[0]]
        hi = [c.gain + 1.96 * c.gain_sd, c.time_constant_s + 1.96 * c.time_constant_sd, c.dead_time_ci95[1]]
        covered.append((np.array(lo) <= truth) & (truth <= np.array(hi)))
        y, u = df["PV"].to_numpy(), df["OP"].to_numpy()
        refs.append(reference_foptd(y, u, r.outputs[0].noise_order, c.delay_samples, c.numerator_length, ts))
    return truth, np.array(est), np.array(refs), np.array(covered), refused, uncertain


def row(label, truth, x, cover=None):
    if len(x) == 0:
        return f"{label:<9}" + " (none identified)"
    scale = np.array([abs(truth[0]) / 100, truth[1] / 100, 1.0])  # %, %, seconds
    bias = (x.mean(axis=0) - truth) / scale
    sd = x.std(axis=0, ddof=1) / scale if len(x) > 1 else np.full(3, np.nan)
    cells = [f"{b:+7.1f} {s:6.1f}" for b, s in zip(bias, sd)]
    cov = "" if cover is None else "  " + " ".join(f"{c:4.2f}" for c in cover.mean(axis=0))
    return f"{label:<9}" + "  ".join(cells) + cov


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=1)
    args = parser.parse_args(argv)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    print(f"PI loops, 751 rows at 10 s (2.1 h), seeds {seeds.start}..{seeds.stop - 1}")
    print("bias / spread: K and tau in % of the truth, theta in s; cover: K tau theta 95 % coverage")
    print(f"{'':<28}{'K bias    sd':>16}  {'tau bias   sd':>14}  {'theta bias  sd':>14}   cover")
    for loop in pi_loop.LOOPS:
        for steps in (False, True):
            truth, est, refs, cov, refused, uncertain = run_case(loop, steps, seeds)
            case = f"{loop.name} {'SP steps' if steps else 'routine'} ({len(est)}/{len(seeds)})"
            print(f"{case}  K={truth[0]:g} tau={truth[1]:g} s theta={truth[2]:g} s"
                  + (f", {refused} not identified" if refused else "")
                  + (f", {uncertain} flagged uncertain" if uncertain else ""))
            print("  " + row("mpmpp", truth, est, cov))
            print("  " + row("scipy-ref", truth, refs))
            if len(est):
                print(f"  max |mpmpp - ref|: K {np.max(np.abs(est[:, 0] - refs[:, 0])):.2g}, "
                      f"tau {np.max(np.abs(est[:, 1] - refs[:, 1])):.2g} s, "
                      f"theta {np.max(np.abs(est[:, 2] - refs[:, 2])):.2g} s")


if __name__ == "__main__":
    main()
