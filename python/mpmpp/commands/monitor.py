"""``mpmpp monitor DETECTOR DATA [--checkpoint FILE]`` or ``mpmpp monitor FLEET``: new data
through a detector saved by ``detect --save-detector``, one loop or a fleet of them."""
from __future__ import annotations

import json
import os


def add_arguments(parser) -> None:
    parser.add_argument("targets", nargs="+", metavar="DETECTOR DATA | FLEET",
                        help="a detector file and a data file (one loop), or a fleet: a folder of LOOP/detector.json "
                             "+ LOOP/data.csv, or a manifest (CSV or JSON: loop, detector, data[, checkpoint])")
    parser.add_argument("--checkpoint", metavar="FILE",
                        help="one loop: resume from FILE if it exists (rows already monitored are passed over) "
                             "and save the stream state there afterwards. The detector's training period counts "
                             "from the first sample the stream ever takes")
    parser.add_argument("--checkpoints", metavar="DIR",
                        help="fleet: keep each loop's checkpoint in DIR/LOOP.checkpoint.json")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="fleet: Dask scheduler address (tcp://host:8786); default: local processes")
    parser.add_argument("--workers", type=int, metavar="K", help="fleet: local processes (default: all cores)")
    parser.add_argument("--csv", metavar="FILE", help="fleet: also write the summary table as CSV")
    parser.add_argument("--force", action="store_true", help="fleet: replace the --csv file if it exists")
    parser.add_argument("--json", action="store_true", help="print one JSON document")


def _one_loop(args) -> int:
    from ..monitor import monitor

    for flag in ("checkpoints", "scheduler", "workers", "csv"):
        if getattr(args, flag) is not None:
            raise ValueError(f"--{flag}: only for a fleet (mpmpp monitor FLEET)")
    result = monitor(args.targets[0], args.targets[1], args.checkpoint)
    print(json.dumps(result.to_dict()) if args.json else result.summary())
    return 0


def _fleet(args) -> int:
    from ..fleet import fleet_csv, format_fleet_table, monitor_fleet

    if args.checkpoint is not None:
        raise ValueError("--checkpoint: for one loop; a fleet keeps its checkpoints with --checkpoints DIR")
    if args.workers is not None and args.workers < 1:
        raise ValueError("--workers: must be >= 1")
    if args.csv and os.path.exists(args.csv) and not args.force:
        raise ValueError(f"{args.csv}: exists; choose another name or pass --force to replace it")
    fleet = monitor_fleet(args.targets[0], args.checkpoints, args.scheduler, args.workers, progress=not args.json)
    if args.csv:
        fleet_csv(fleet, args.csv)
    print(json.dumps(fleet) if args.json else format_fleet_table(fleet) + f"\n(ran on {fleet['where']})")
    return 0


def run(args) -> int:
    if len(args.targets) == 2:
        return _one_loop(args)
    if len(args.targets) == 1:
        return _fleet(args)
    raise ValueError("expected DETECTOR DATA (one loop) or FLEET (a folder or manifest), got "
                     f"{len(args.targets)} arguments")
