"""The ``mpmpp`` command line (contract: shared FORMATS.md).

Each subcommand lives in its own module under ``mpmpp.commands`` exposing
``add_arguments(parser)`` and ``run(args) -> int``. A subcommand whose module is
not listed yet answers "not available yet" with exit code 2.
Bad input (ValueError, OSError on the user's files) becomes one line on stderr
and exit code 2, never a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from . import __version__

# name -> (one-line help, module implementing it or None while not built yet)
COMMANDS: dict[str, tuple[str, str | None]] = {
    "demo": ("reproduce the paper's example end to end (simulate, detect, plot)", None),
    "simulate": ("closed-loop simulation with MPC and scheduled plant/noise changes", "mpmpp.commands.simulate"),
    "evaluate": ("Monte Carlo: detection and false-alarm rates, delays, against baselines", None),
    "compare": ("model vs measurements: fit per output, residual tests, where it fails", None),
    "detect": ("moving-window MPM and noise-change detection per channel", None),
    "diagnose": ("ranked findings: which physical effect is missing, where, when", None),
    "update": ("add/refit the effect(s), write the new model, print error before and after", None),
    "check": ("validate a model file (and a data file against it) and summarise them", "mpmpp.commands.check"),
}


class UserError(Exception):
    """A problem with what the user gave us; printed as one line, exit code 2."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mpmpp",
        description="Model-plant mismatch detection and model diagnosis from routine closed-loop data.",
    )
    parser.add_argument("--version", action="version", version=f"mpmpp {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (help_text, module) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        if module is not None:
            importlib.import_module(module).add_arguments(p)
        else:
            p.add_argument("args", nargs=argparse.REMAINDER, help=argparse.SUPPRESS)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    module = COMMANDS[args.command][1]
    if module is None:
        print(f"mpmpp {args.command}: not available yet", file=sys.stderr)
        return 2
    try:
        return int(importlib.import_module(module).run(args) or 0)
    except (UserError, ValueError, OSError) as exc:
        print(f"mpmpp {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
