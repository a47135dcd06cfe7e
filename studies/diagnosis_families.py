"""Diagnosis on scenario families: accuracy of the top process finding per effect, false
process findings on the controls, update quality (shown error next to the true model error)
and the confidence reliability table, the held-out families next to the tuning families
(docs/diagnose.md, docs/families.md).

    python studies/diagnosis_families.py [--seeds N] [--first-seed S] [--families A,B]
                                         [--workers K] [--json OUT.json]

Every effect a family schedules (the controls included) runs once per seed. Tuning seeds
0-99 are for choosing; reports use seeds from 100 on (the default). Runs on all local cores
(mpmpp.parallel.run_tasks) or on a Dask cluster (--scheduler ADDRESS).
"""
from __future__ import annotations

import argparse
import json
import sys

from mpmpp.diagnosis_study import format_tables, run_study
from mpmpp.io import atomic_output


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=4, help="runs per family and effect (default 4)")
    p.add_argument("--first-seed", type=int, default=100, help="seeds S..S+N-1 (default 100)")
    p.add_argument("--families", help="comma-separated family names (default: all)")
    p.add_argument("--workers", type=int, help="local processes (default: all cores)")
    p.add_argument("--scheduler", help="Dask scheduler address instead of local processes")
    p.add_argument("--json", metavar="OUT.json", help="also write every run as JSON")
    args = p.parse_args(argv)
    if args.seeds < 1 or args.first_seed < 0:
        p.error("--seeds must be >= 1 and --first-seed >= 0")
    names = None if args.families is None else [n.strip() for n in args.families.split(",")]
    try:
        study = run_study(names, range(args.first_seed, args.first_seed + args.seeds),
                          scheduler=args.scheduler, workers=args.workers)
    except ValueError as exc:
        print(f"diagnosis_families: error: {exc}", file=sys.stderr)
        return 2
    print(format_tables(study))
    if args.json:
        with atomic_output(args.json) as f:
            json.dump(study, f, indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())
