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
from mpmpp.families import add_study_arguments, study_selection
from mpmpp.io import atomic_output


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_study_arguments(p, "family and effect", first_seed=100)
    args = p.parse_args(argv)
    names, seeds = study_selection(p, args)
    try:
        study = run_study(names, seeds, scheduler=args.scheduler, workers=args.workers,
                          channel_switch=args.channel_switch, earlier_noise_change=args.earlier_noise_change)
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
