"""``mpmpp diagnose MODEL DATA``: ranked findings (formats.md ``diagnose --json``)."""
from __future__ import annotations

from ._pair import add_pair_arguments, load_pair, report


def add_arguments(parser) -> None:
    add_pair_arguments(parser)
    parser.add_argument("--train-end", type=float, metavar="SECONDS",
                        help="data before this time are taken to agree with the model")


def run(args) -> int:
    from ..diagnose import diagnose

    model, data = load_pair(args.model, args.data)
    result = diagnose(model, data, train_end_s=args.train_end)
    return report(result, args, "diagnose")
