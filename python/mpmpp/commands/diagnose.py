"""``mpmpp diagnose MODEL DATA``: ranked findings (FORMATS.md ``diagnose --json``)."""
from __future__ import annotations

import json
from pathlib import Path

from ._pair import add_pair_arguments, load_pair


def add_arguments(parser) -> None:
    add_pair_arguments(parser)
    parser.add_argument("--train-end", type=float, metavar="SECONDS",
                        help="data before this time are taken to agree with the model")


def run(args) -> int:
    from ..diagnose import diagnose

    model, data = load_pair(args.model, args.data)
    result = diagnose(model, data, train_end_s=args.train_end)
    if args.out:
        paths = result.plot(args.out)
        (Path(args.out) / "diagnose.json").write_text(json.dumps(result.to_dict(), indent=1))
    if args.json:
        print(json.dumps(result.to_dict()))
    else:
        print(result.summary())
        if args.out:
            print(f"  figures: {', '.join(str(p) for p in paths)}")
    return 0
