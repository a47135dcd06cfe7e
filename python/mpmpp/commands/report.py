"""``mpmpp report MODEL DATA -o report.html``: the whole analysis as one self-contained page."""
from __future__ import annotations

from ._pair import add_pair_arguments, add_train_end_argument, load_pair, train_end


def add_arguments(parser) -> None:
    add_pair_arguments(parser, outputs=False)
    parser.add_argument("-o", "--output", required=True, metavar="FILE.html", help="the page to write")
    add_train_end_argument(parser, help_text="end of the period the model is trusted (detect: default the "
                           "config's training duration; diagnose: default none)")
    parser.add_argument("--config", metavar="FILE", help="detector config JSON or preset name, as for detect")
    parser.add_argument("--force", action="store_true", help="replace FILE.html if it exists")


def run(args) -> int:
    import os

    from ..report import build_report, write_report
    from .diagnose import monitoring_s

    if os.path.exists(args.output) and not args.force:
        raise ValueError(f"{args.output}: exists; choose another name or pass --force to replace it")
    model, data, clock = load_pair(args)
    end = train_end(args, clock, monitoring_s(model, data), "the report's diagnose and detect")
    page = build_report(model, data, args.model, args.data, None if end is None else end - clock.start_s,
                        args.config)
    write_report(args.output, page, force=args.force)
    print(f"wrote {args.output}")
    return 0
