"""``mpmpp update MODEL DATA --apply F1[,F2] -o NEW_MODEL``: apply findings, write the model."""
from __future__ import annotations

import json

from ._pair import (add_pair_arguments, add_train_end_argument, load_pair, result_document,
                    summary_in_data_time, train_end)
from .diagnose import MONITORING_S


def add_arguments(parser) -> None:
    add_pair_arguments(parser)
    parser.add_argument("--apply", required=True, metavar="ID[,ID...]",
                        help="finding ids from `mpmpp diagnose` (e.g. F1,F2)")
    parser.add_argument("-o", "--output", required=True, metavar="NEW_MODEL", help="model file to write")
    add_train_end_argument(parser, help_text="as for diagnose (the same findings are re-derived)")


def run(args) -> int:
    from ..update import update

    model, data, clock = load_pair(args)
    end = train_end(args, clock, MONITORING_S, "update (diagnose)")
    result = update(model, data, args.apply, train_end_s=end)
    result.save(args.output)
    if args.out:
        result.plot(args.out)
    if args.json:
        print(json.dumps({**result_document(result, clock), "model": args.output}))
    else:
        print(summary_in_data_time(result, clock))
        print(f"  wrote {args.output}")
    return 0
