"""``diagnose`` on 2 h PI-loop records with a few PV samples lost: the same top process finding
as on the complete record?

Records as in studies/standing_errors.py (tests/python/pi_loop.py loops, 751 rows at 10 s,
setpoint steps), each diagnosed complete and with k = 2, 4 and 7 PV samples lost at random rows
(7 is 0.9 %, under the 1 % that signals.bridge_lost_outputs interpolates); models: the
hand-written FOPTD with the gain doubled, halved, or right. "same" counts runs whose top process
finding (effect, or none) matches the complete record's; "refused" runs diagnose refused.

    PYTHONPATH=python python studies/diagnose_gaps.py --loops held-out --seeds 4 --first-seed 101
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))

import standing_errors as records  # noqa: E402  (also puts tests/python on the path)

import pi_loop  # noqa: E402

from mpmpp.diagnose import PROCESS_EFFECTS, diagnose  # noqa: E402
from mpmpp.parallel import run_tasks  # noqa: E402

LOST = (2, 4, 7)
MODELS = (("gain", 2.0), ("gain", 0.5), ("none", 1.0))


def top_process(loop_name: str, parameter: str, factor: float, seed: int, lost: int) -> dict:
    loop = next(lp for lp in pi_loop.LOOPS + records.HELD_OUT_LOOPS if lp.name == loop_name)
    data = pi_loop.simulate(loop, seed, setpoint_steps=True)
    if lost:
        rows = np.random.default_rng(1000 + seed).choice(np.arange(5, len(data) - 5), lost, replace=False)
        data.loc[rows, "PV"] = np.nan
    key = {"loop": loop_name, "parameter": parameter, "factor": factor, "seed": seed, "lost": lost}
    try:
        result = diagnose(records.hand_written(loop, parameter, factor), data)
    except ValueError as exc:
        return {**key, "refused": str(exc)}
    process = [f.effect for f in result.findings if f.effect in PROCESS_EFFECTS]
    return {**key, "refused": None, "top": process[0] if process else None}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=4)
    p.add_argument("--first-seed", type=int, default=1)
    p.add_argument("--loops", choices=sorted(records.LOOP_SETS), default="tuning")
    p.add_argument("--workers", type=int, default=None)
    args = p.parse_args(argv)
    loops = records.LOOP_SETS[args.loops]
    started = time.perf_counter()
    tasks = [(lp.name, parameter, factor, seed, lost) for lp in loops for parameter, factor in MODELS
             for seed in range(args.first_seed, args.first_seed + args.seeds) for lost in (0,) + LOST]
    runs, where = run_tasks(top_process, tasks, None, args.workers, True, unit="runs")
    complete = {(r["loop"], r["parameter"], r["factor"], r["seed"]): r for r in runs if r["lost"] == 0}
    print(f"{args.loops} loops {', '.join(lp.name for lp in loops)}; seeds {args.first_seed}-"
          f"{args.first_seed + args.seeds - 1}; {time.perf_counter() - started:.0f} s wall on {where}\n")
    print("| PV samples lost | runs | same top process finding as complete | different | refused |")
    print("| --- | --- | --- | --- | --- |")
    for lost in LOST:
        rs = [r for r in runs if r["lost"] == lost]
        base = [complete[(r["loop"], r["parameter"], r["factor"], r["seed"])] for r in rs]
        same = sum(r["refused"] is None and b["refused"] is None and r["top"] == b["top"] for r, b in zip(rs, base))
        refused = sum(r["refused"] is not None for r in rs)
        print(f"| {lost} | {len(rs)} | {same} | {len(rs) - same - refused} | {refused} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
