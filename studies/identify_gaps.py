"""What gaps in a historian export cost ``mpmpp identify``: every complete stretch fitted (each
from rest) against the longest stretch alone (the method before 2026-11-29) and the record
without gaps.

Loops: flow / pressure / level-like PI loops with setpoint steps (tests/python/pi_loop.py, plain
NumPy), 6 h at 10 s (2,160 rows). Gaps: one row lost (OP and PV) every ``--every`` rows (a
historian that drops a sample now and then); at 140 rows no stretch reaches the 150 rows a
record needs, so the longest stretch alone is always refused. Columns as in
studies/identify_study.py: bias and spread (sd over seeds) in % of the true value for K and tau,
in seconds for theta, then the share of seeds whose 95 % interval holds the truth; refused seeds
are counted and left out.

    PYTHONPATH=python python studies/identify_gaps.py --seeds 10 --every 140 400
"""
from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))
sys.path.insert(0, str(ROOT / "studies"))

import pi_loop  # noqa: E402
from identify_study import row  # noqa: E402

from mpmpp.model_identification import NotIdentified, model_from_data  # noqa: E402
from mpmpp.signals import complete_runs, longest  # noqa: E402

ROWS = 2160


def variants(df, every):
    """The record three ways: without gaps, with a row lost (OP and PV) every ``every`` rows, and
    the longest complete stretch of the latter alone. A lost input ends a stretch; PV samples
    lost alone, this few, would be interpolated (signals.bridge_lost_outputs)."""
    gapped = df.copy()
    gapped.loc[every - 1::every, ["OP", "PV"]] = np.nan
    a, b = longest(complete_runs(gapped["PV"].notna().to_numpy()))
    return {"no gaps": df, "gaps, every stretch": gapped, "gaps, longest only": gapped.iloc[a:b]}


def summary(fits, truth):
    """(estimates, coverage flags, refused count) of one variant over the seeds."""
    est, cover, refused = [], [], 0
    for r in fits:
        if r is None or r.channels[0].integrating:
            refused += 1
            continue
        c = r.channels[0]
        est.append([c.gain, c.time_constant_s, c.dead_time_s])
        lo = [c.gain - 1.96 * c.gain_sd, c.time_constant_s - 1.96 * c.time_constant_sd, c.dead_time_ci95[0]]
        hi = [c.gain + 1.96 * c.gain_sd, c.time_constant_s + 1.96 * c.time_constant_sd, c.dead_time_ci95[1]]
        cover.append((np.array(lo) <= truth) & (truth <= np.array(hi)))
    return np.array(est), np.array(cover), refused


def identify(df):
    try:
        return model_from_data(df, ["OP"], ["PV"])
    except (NotIdentified, ValueError):  # not identified, or no stretch long enough
        return None


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--every", type=int, nargs="+", default=[140, 400],
                        help="one row lost (OP and PV) every this many rows")
    args = parser.parse_args(argv)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    for every in args.every:
        print(f"\nrow lost every {every} rows; {ROWS} rows at 10 s, setpoint steps, seeds "
              f"{seeds.start}-{seeds.stop - 1}")
        print(f"{'loop':<9} {'variant':<20} {'rows':>5} {'refused':>7}   K: bias sd %   tau: bias sd %"
              "   theta: bias sd s   cover K tau theta")
        for loop in (pi_loop.FLOW, pi_loop.PRESSURE, pi_loop.LEVEL):
            truth = np.array([loop.gain, loop.time_constant_s, loop.dead_time_s])
            scale = np.array([abs(loop.gain) / 100, loop.time_constant_s / 100, 1.0])
            fits = {}
            for seed in seeds:
                df = pi_loop.simulate(loop, seed, rows=ROWS, setpoint_steps=True)
                for name, data in variants(df, every).items():
                    fits.setdefault(name, []).append(identify(data))
            for name, rs in fits.items():
                est, cover, refused = summary(rs, truth)
                used = [r.rows_used for r in rs if r is not None]
                rows = f"{np.median(used):5.0f}" if used else "    -"
                print(f"{loop.name:<9} {name:<20} {rows} {refused:>7}  "
                      + row("", truth, est, scale, cover if len(cover) else None).strip())


if __name__ == "__main__":
    main()
