"""``mpmpp update MODEL DATA --apply F1[,F2] -o NEW_MODEL``: apply findings, write the model."""
from __future__ import annotations

import json
import os

from ._pair import (add_pair_arguments, add_train_end_argument, load_pair, result_document,
                    summary_in_data_time, train_end)
from .diagnose import add_length_arguments, length_options, monitoring_s


def add_arguments(parser) -> None:
    add_pair_arguments(parser)
    parser.add_argument("--apply", required=True, metavar="ID[,ID...]",
                        help="finding ids from `mpmpp diagnose` (e.g. F1,F2)")
    parser.add_argument("-o", "--output", required=True, metavar="NEW_MODEL",
                        help="model file to write (must not exist yet, unless --force)")
    parser.add_argument("--force", action="store_true",
                        help="replace NEW_MODEL if it exists, even when it is MODEL itself")
    add_train_end_argument(parser, help_text="as for diagnose (the same findings are re-derived)")
    add_length_arguments(parser)


def replaces_existing(model_path: str, output_path: str, force: bool) -> bool:
    """Whether writing ``output_path`` replaces an existing file; that is an error without ``force``.
    Checked before any work, so a refusal costs nothing; the input model is named as such,
    since losing it loses the nominal model the findings were measured against."""
    if not os.path.exists(output_path):
        return False
    if not force:
        if os.path.exists(model_path) and os.path.samefile(model_path, output_path):
            raise ValueError(f"{output_path}: is the input model; write the new model to another file "
                             f"or pass --force to replace it")
        raise ValueError(f"{output_path}: exists; choose another file or pass --force to replace it")
    return True


def run(args) -> int:
    from ..update import update

    replaces = replaces_existing(args.model, args.output, args.force)
    model, data, clock = load_pair(args)
    lengths = length_options(args)
    end = train_end(args, clock, monitoring_s(model, data, lengths["min_segment_s"]), "update (diagnose)")
    result = update(model, data, args.apply, train_end_s=end, **lengths)
    result.save(args.output)
    doc = {**result_document(result, clock), "model": args.output, "replaced": replaces}
    if args.out:
        from pathlib import Path

        from ..io import atomic_output

        result.plot(args.out)
        with atomic_output(Path(args.out) / "update.json") as f:
            f.write(json.dumps(doc, indent=1))
    if args.json:
        print(json.dumps(doc))
    else:
        print(summary_in_data_time(result, clock))
        print(f"  {'replaced' if replaces else 'wrote'} {args.output}")
    return 0
