"""``mpmpp update MODEL DATA --apply F1[,F2] -o NEW_MODEL``: apply findings, write the model."""
from __future__ import annotations

import json

from ._pair import add_pair_arguments, load_pair


def add_arguments(parser) -> None:
    add_pair_arguments(parser)
    parser.add_argument("--apply", required=True, metavar="ID[,ID...]",
                        help="finding ids from `mpmpp diagnose` (e.g. F1,F2)")
    parser.add_argument("-o", "--output", required=True, metavar="NEW_MODEL", help="model file to write")
    parser.add_argument("--train-end", type=float, metavar="SECONDS",
                        help="as for diagnose (the same findings are re-derived)")


def run(args) -> int:
    from ..update import update

    model, data = load_pair(args.model, args.data)
    result = update(model, data, args.apply, train_end_s=args.train_end)
    result.save(args.output)
    if args.out:
        result.plot(args.out)
    if args.json:
        print(json.dumps({**result.to_dict(), "model": args.output}))
    else:
        print(result.summary())
        print(f"  wrote {args.output}")
    return 0
