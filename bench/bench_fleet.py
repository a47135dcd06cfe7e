"""Fleet monitoring throughput against the number of workers (``mpmpp monitor FLEET``).

    PYTHONPATH=python python bench/bench_fleet.py [--loops 64] [--hours 8] [--workers 1,2,4]
                                                  [--scheduler tcp://host:8786]

Builds a fleet of loops from the committed stream test record (tests/data/stream: the paper
SISO scenario and its saved detector): each loop is an --hours stretch starting at a
different time. Then monitors the whole fleet with K local processes for each K in
--workers and prints loops per second and the speed-up against one worker, the named peer:
the same fleet monitored by a single process. With --scheduler the fleet runs once on that
Dask cluster, against one local process. Wall-clock seconds, best of
--repeats. On a machine with C free cores the ideal ratio is min(K, C).
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time

import pandas as pd

from mpmpp.fleet import monitor_fleet

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STREAM = os.path.join(ROOT, "tests", "data", "stream")


def make_fleet(folder: str, loops: int, hours: float) -> str:
    df = pd.read_csv(os.path.join(STREAM, "data.csv"))
    rows = int(hours * 3600 / 5)
    if rows > len(df):
        raise SystemExit(f"--hours: the record holds {len(df) * 5 / 3600:g} h")
    lines = ["loop,detector,data"]
    for k in range(loops):
        off = round(k * (len(df) - rows) / max(loops - 1, 1))
        df.iloc[off:off + rows].to_csv(os.path.join(folder, f"loop{k:04d}.csv"), index=False, float_format="%.17g",
                                       na_rep="")
        lines.append(f"loop{k:04d},{os.path.join(STREAM, 'detector.json')},loop{k:04d}.csv")
    manifest = os.path.join(folder, "fleet.csv")
    with open(manifest, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    return manifest


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--loops", type=int, default=64)
    ap.add_argument("--hours", type=float, default=8.0)
    ap.add_argument("--workers", default=",".join(str(k) for k in (1, 2, 4) if k <= (os.cpu_count() or 1)) or "1")
    ap.add_argument("--scheduler", help="a Dask scheduler address instead of local processes")
    ap.add_argument("--repeats", type=int, default=1)
    args = ap.parse_args()
    counts = [int(k) for k in args.workers.split(",")]
    if args.scheduler:
        counts = [1, None]  # None: the cluster
    with tempfile.TemporaryDirectory() as folder:
        manifest = make_fleet(folder, args.loops, args.hours)
        print(f"{args.loops} loops of {args.hours:g} h; {os.cpu_count()} cores here")
        print(f"{'workers':>7} {'wall s':>8} {'loops/s':>8} {'speed-up vs 1':>13}  where")
        base = None
        table = None
        for k in counts:
            best = float("inf")
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                fleet = monitor_fleet(manifest, scheduler=args.scheduler if k is None else None, workers=k)
                best = min(best, time.perf_counter() - t0)
            if table is None:
                table = fleet["loops"]
            elif fleet["loops"] != table:
                raise SystemExit("the table changed with the number of workers")
            base = base or best
            print(f"{k or 'Dask':>7} {best:>8.2f} {args.loops / best:>8.1f} {base / best:>13.2f}  {fleet['where']}")


if __name__ == "__main__":
    main()
