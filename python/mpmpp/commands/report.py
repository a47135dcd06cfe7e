"""``mpmpp report MODEL DATA -o report.html``: the whole analysis as one self-contained page."""
from __future__ import annotations


def add_arguments(parser) -> None:
    parser.add_argument("model", metavar="MODEL", help="nominal model file (JSON, FORMATS.md)")
    parser.add_argument("data", metavar="DATA", help="operating data (CSV, FORMATS.md)")
    parser.add_argument("-o", "--output", required=True, metavar="FILE.html", help="the page to write")
    parser.add_argument("--train-end", type=float, metavar="SECONDS",
                        help="end of the period the model is trusted, seconds after the first sample (detect: "
                             "default the config's training duration; diagnose: default none)")
    parser.add_argument("--config", metavar="FILE", help="detector config JSON or preset name, as for detect")
    parser.add_argument("--force", action="store_true", help="replace FILE.html if it exists")


def run(args) -> int:
    import os

    from ..report import build_report, write_report

    if os.path.exists(args.output) and not args.force:
        raise ValueError(f"{args.output}: exists; choose another name or pass --force to replace it")
    write_report(args.output, build_report(args.model, args.data, args.train_end, args.config), force=args.force)
    print(f"wrote {args.output}")
    return 0
