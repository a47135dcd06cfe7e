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

Integrating loops (tank levels: a pure integrator and one behind a 60 s lag with an inflow
disturbance, a pure integrator with transmitter noise; routine and with setpoint steps of 0.5 %): how often the integrating class is chosen, the rate gain's bias and spread in % and the
mean delay theta + tau in seconds (what a record of this length determines: a lag the data do
not resolve shows as dead time); the reference is SciPy's joint fit of the differenced level.

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


def reference_integrating(y, u, na, delay, nb, nf, ts, noise_integrates=True):
    """SciPy's joint prediction-error fit of the differenced level (mean removed), or of the level
    against the integrated input when the disturbance does not integrate, then the rate
    gain K and the mean delay theta + tau: the first moment of q^-d (b0 + b1 q^-1) / (1 - a q^-1)
    in samples is (theta + tau) / Ts + 1."""
    if noise_integrates:
        dy = np.r_[0.0, np.diff(y - y.mean())]
        b, f, _ = ref.pem_ar_noise(dy - dy.mean(), u, na, nb, delay, nf=nf)
    else:  # the output against the integrated input
        b, f, _ = ref.pem_ar_noise(y, np.cumsum(u - u.mean()), na, nb, delay, nf=nf)
    a = -f[1] if nf else 0.0
    share = b[1] / b.sum() if nb == 2 else 0.0
    return b.sum() / ((1 - a) * ts), (delay - 1 + share + a / (1 - a)) * ts


def run_integrating(loop, steps, seeds, ts=10.0, rows=751, step_size=0.5):
    """Per seed (rate gain, mean delay) of mpmpp and the reference, the 95 % coverage of the
    rate gain, the seeds refused, those where an integrating class was chosen and those where it
    was the one with a lag."""
    est, refs, covered, refused, integrating, lagged = [], [], [], 0, 0, 0
    for seed in seeds:
        df, r = identified(loop, seed, steps, rows, ts, step_size=step_size)
        if r is None:
            refused += 1
            continue
        c = r.channels[0]
        if not c.integrating:
            continue
        integrating += 1
        lagged += c.time_constant_s > 0
        est.append([c.gain, c.dead_time_s + c.time_constant_s])
        covered.append(abs(c.gain - loop.gain) <= 1.96 * c.gain_sd)
        nf = 1 if c.time_constant_s > 0 else 0
        refs.append(reference_integrating(df["PV"].to_numpy(), df["OP"].to_numpy(), r.outputs[0].noise_order,
                                          c.delay_samples, c.numerator_length, nf, ts,
                                          "disturbance at the output" not in r.outputs[0].process_class))
    return np.array(est), np.array(refs), np.array(covered), refused, integrating, lagged


def identified(loop, seed, steps, rows, ts, **simulate):
    """A simulated record of loop and mpmpp's identification of it (None when refused)."""
    df = pi_loop.simulate(loop, seed, rows=rows, ts=ts, setpoint_steps=steps, **simulate)
    try:
        return df, model_from_data(df, ["OP"], ["PV"])
    except NotIdentified:
        return df, None


def run_case(loop, steps, seeds, ts=10.0, rows=751):
    """Per seed (K, tau, theta) of mpmpp and the reference, their coverage, the seeds refused and
    flagged uncertain, and for the seeds called integrating their rate gain over the initial slope
    K / tau (left out of the statistics)."""
    est, refs, covered, refused, uncertain, slopes = [], [], [], 0, 0, []
    truth = np.array([loop.gain, loop.time_constant_s, loop.dead_time_s])
    for seed in seeds:
        df, r = identified(loop, seed, steps, rows, ts)
        if r is None:
            refused += 1
            continue
        c = r.channels[0]
        if c.integrating:
            slopes.append(c.gain / (loop.gain / loop.time_constant_s))
            continue
        uncertain += c.uncertain
        est.append([c.gain, c.time_constant_s, c.dead_time_s])
        lo = [c.gain - 1.96 * c.gain_sd, c.time_constant_s - 1.96 * c.time_constant_sd, c.dead_time_ci95[0]]
        hi = [c.gain + 1.96 * c.gain_sd, c.time_constant_s + 1.96 * c.time_constant_sd, c.dead_time_ci95[1]]
        covered.append((np.array(lo) <= truth) & (truth <= np.array(hi)))
        y, u = df["PV"].to_numpy(), df["OP"].to_numpy()
        refs.append(reference_foptd(y, u, r.outputs[0].noise_order, c.delay_samples, c.numerator_length, ts))
    return truth, np.array(est), np.array(refs), np.array(covered), refused, uncertain, slopes


def row(label, truth, x, scale, cover=None, empty=" (none identified)"):
    """Bias and spread of the estimates x (rows) against truth, in units of scale per column,
    and the mean of cover (per column, or one flag per seed)."""
    if len(x) == 0:
        return f"{label:<9}" + empty
    bias = (x.mean(axis=0) - truth) / scale
    sd = x.std(axis=0, ddof=1) / scale if len(x) > 1 else np.full(len(truth), np.nan)
    cells = [f"{b:+7.1f} {s:6.1f}" for b, s in zip(bias, sd)]
    cov = "" if cover is None else "  " + " ".join(f"{c:4.2f}" for c in np.atleast_1d(cover.mean(axis=0)))
    return f"{label:<9}" + "  ".join(cells) + cov


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--integrating-only", action="store_true", help="only the integrating levels")
    args = parser.parse_args(argv)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    print(f"PI loops, 751 rows at 10 s (2.1 h), seeds {seeds.start}..{seeds.stop - 1}")
    if not args.integrating_only:
        print_self_regulating(seeds)
    print("\nintegrating levels (routine; SP steps of 0.5 %): rate gain K in % of the truth, mean delay theta + tau"
          " in s; cover: K")
    print(f"{'':<11}{'K bias    sd':>14}  {'delay bias  sd':>14}  cover")
    for loop in pi_loop.INTEGRATING_LOOPS:
        for steps in (False, True):
            print_integrating(loop, steps, seeds)


def print_self_regulating(seeds):
    print("bias / spread: K and tau in % of the truth, theta in s; cover: K tau theta 95 % coverage")
    print(f"{'':<28}{'K bias    sd':>16}  {'tau bias   sd':>14}  {'theta bias  sd':>14}   cover")
    for loop in pi_loop.LOOPS:
        for steps in (False, True):
            truth, est, refs, cov, refused, uncertain, slopes = run_case(loop, steps, seeds)
            case = f"{loop.name} {'SP steps' if steps else 'routine'} ({len(est)}/{len(seeds)})"
            print(f"{case}  K={truth[0]:g} tau={truth[1]:g} s theta={truth[2]:g} s"
                  + (f", {refused} not identified" if refused else "")
                  + (f", {uncertain} flagged uncertain" if uncertain else "")
                  + (f", {len(slopes)} called integrating (rate gain / (K / tau): "
                     + ", ".join(f"{x:.2f}" for x in slopes) + ")" if slopes else ""))
            scale = np.array([abs(truth[0]) / 100, truth[1] / 100, 1.0])  # %, %, seconds
            print("  " + row("mpmpp", truth, est, scale, cov))
            print("  " + row("scipy-ref", truth, refs, scale))
            if len(est):
                print(f"  max |mpmpp - ref|: K {np.max(np.abs(est[:, 0] - refs[:, 0])):.2g}, "
                      f"tau {np.max(np.abs(est[:, 1] - refs[:, 1])):.2g} s, "
                      f"theta {np.max(np.abs(est[:, 2] - refs[:, 2])):.2g} s")


def print_integrating(loop, steps, seeds):
    est, refs, cov, refused, integrating, lagged = run_integrating(loop, steps, seeds)
    print(f"{loop.name} {'SP steps' if steps else 'routine'}  K={loop.gain:g}/s tau={loop.time_constant_s:g} s"
          f" theta={loop.dead_time_s:g} s: integrating class on {integrating}/{len(seeds)}"
          f" ({lagged} with a lag)"
          + (f", {refused} not identified" if refused else ""))
    truth = np.array([loop.gain, loop.dead_time_s + loop.time_constant_s])
    scale = np.array([loop.gain / 100, 1.0])  # %, seconds
    empty = " (none identified as integrating)"
    print("  " + row("mpmpp", truth, est, scale, cov, empty))
    print("  " + row("scipy-ref", truth, refs, scale, empty=empty))
    if len(est):
        print(f"  max |mpmpp - ref|: K {np.max(np.abs(est[:, 0] - refs[:, 0]) / abs(loop.gain)):.2g} (relative),"
              f" delay {np.max(np.abs(est[:, 1] - refs[:, 1])):.2g} s")


if __name__ == "__main__":
    main()
