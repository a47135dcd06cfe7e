"""``mpmpp evaluate SCENARIO --seeds N``: Monte Carlo detection/false-alarm rates and delays,
the detector against the variance and residual baselines on the same runs.
``mpmpp evaluate --families [NAME,...] --seeds N``: the same per scenario family and preset,
tuning families next to held-out ones (docs/families.md)."""
from __future__ import annotations

import json


def add_arguments(parser) -> None:
    parser.add_argument("scenario", nargs="?", help="paper_siso | paper_mimo (the paper's examples) | a scenario JSON file")
    parser.add_argument("--families", nargs="?", const="all", metavar="NAME,...",
                        help="evaluate scenario families instead (all, or a comma-separated list; docs/families.md)")
    parser.add_argument("--seeds", type=int, default=20, metavar="N", help="number of runs (default 20)")
    parser.add_argument("--first-seed", type=int, default=0, metavar="S",
                        help="seeds S..S+N-1 (default 0; e.g. 100 for runs held out from a choice made on 0..99)")
    parser.add_argument("--config", metavar="FILE", help="detector config JSON or preset name (siso, mimo, paper_siso, paper_mimo; default: the recommended preset for the model size)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="Dask scheduler address (tcp://host:8786); default: local processes")
    parser.add_argument("--workers", type=int, metavar="K", help="local processes (default: all cores)")
    parser.add_argument("--json", action="store_true", help="print the summary as one JSON document")


def run(args) -> int:
    from ..evaluate import evaluate, format_table

    if args.seeds < 1:
        raise ValueError("--seeds: must be >= 1")
    if args.first_seed < 0:
        raise ValueError("--first-seed: must be >= 0")
    if args.workers is not None and args.workers < 1:
        raise ValueError("--workers: must be >= 1")
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    if (args.scenario is None) == (args.families is None):
        raise ValueError("give either SCENARIO or --families")
    if args.families is not None:
        from ..family_study import format_table as family_table, run_study

        if args.config:
            raise ValueError("--config: with --families every preset of the family's size runs")
        names = None if args.families == "all" else [n.strip() for n in args.families.split(",")]
        study = run_study(names, seeds, scheduler=args.scheduler, workers=args.workers, progress=not args.json)
        print(json.dumps(study) if args.json else family_table(study))
        return 0
    summary = evaluate(args.scenario, seeds, config=args.config, scheduler=args.scheduler,
                       workers=args.workers, progress=not args.json)
    if args.json:
        print(json.dumps(summary))
    else:
        print(format_table(summary))
    return 0
