"""Detection and false-alarm rates, and delays, per scenario family and preset: the held-out
families next to the tuning families (docs/families.md).

    python studies/detection_families.py [--seeds N] [--first-seed S] [--families A,B]
                                         [--workers K] [--json OUT.json]
                                         [--config LABEL=CONFIG ...] [--record-hours H]

--config (repeatable) scores detector configs instead of the presets of each family's size:
CONFIG is a preset name, a config file or inline JSON ({"preset": "siso", "window_s": 14400}).
Configs are compared on tuning families and seeds 0-99 only (docs/families.md).
--record-hours cuts every draw's record to H hours (the change moves into it: Family.draw),
e.g. to study historian-length records on the tuning families.

Runs on all local cores by default (mpmpp.parallel.run_tasks), or on a Dask cluster
(--scheduler ADDRESS). Equivalent: ``mpmpp evaluate --families --seeds N``.
"""
from __future__ import annotations

import argparse
import json
import sys

from mpmpp.families import add_study_arguments, study_selection
from mpmpp.family_study import format_table, run_study
from mpmpp.io import atomic_output


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_study_arguments(p, "family", first_seed=0)
    p.add_argument("--config", action="append", metavar="LABEL=CONFIG",
                   help="score this detector config (preset name, file or inline JSON) under LABEL")
    p.add_argument("--record-hours", type=float, metavar="H", help="cut every record to H hours")
    args = p.parse_args(argv)
    names, seeds = study_selection(p, args)
    configs = None
    for item in args.config or []:
        label, sep, given = item.partition("=")
        if not sep or not label or not given:
            p.error(f"--config {item!r}: expected LABEL=CONFIG")
        try:
            configs = {**(configs or {}), label: json.loads(given) if given.lstrip().startswith("{") else given}
        except json.JSONDecodeError as exc:
            p.error(f"--config {label}: not valid JSON ({exc})")
    try:
        if args.record_hours is not None and not args.record_hours > 0:
            raise ValueError(f"--record-hours must be > 0, got {args.record_hours}")
        study = run_study(names, seeds, 3600 * args.record_hours if args.record_hours else None,
                          scheduler=args.scheduler, workers=args.workers, configs=configs,
                          channel_switch=args.channel_switch, earlier_noise_change=args.earlier_noise_change)
    except ValueError as exc:
        print(f"detection_families: error: {exc}", file=sys.stderr)
        return 2
    print(format_table(study))
    if args.json:
        with atomic_output(args.json) as f:
            json.dump(study, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
