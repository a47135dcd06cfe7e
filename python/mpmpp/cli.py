"""The ``mpmpp`` command line (contract: shared FORMATS.md).

Each subcommand lives in its own module under ``mpmpp.commands`` exposing
``add_arguments(parser)`` and ``run(args) -> int``.
Bad input (ValueError, OSError on the user's files) becomes one line on stderr
and exit code 2, never a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from . import __version__

# name -> (one-line help, module implementing it)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("reproduce the paper's example end to end (simulate, detect, plot)", "mpmpp.commands.demo"),
    "simulate": ("closed-loop simulation with MPC and scheduled plant/noise changes", "mpmpp.commands.simulate"),
    "evaluate": ("Monte Carlo: detection and false-alarm rates, delays, against baselines", "mpmpp.commands.evaluate"),
    "compare": ("model vs measurements: fit per output, residual tests, where it fails", "mpmpp.commands.compare"),
    "detect": ("moving-window MPM and noise-change detection per channel", "mpmpp.commands.detect"),
    "diagnose": ("ranked findings: which physical effect is missing, where, when", "mpmpp.commands.diagnose"),
    "update": ("add/refit the effect(s), write the new model, print error before and after", "mpmpp.commands.update"),
    "stiction": ("valve stiction in a PI loop from OP and PV, with the literature tests beside it", "mpmpp.commands.stiction"),
    "check": ("validate a model file (and a data file against it) and summarise them", "mpmpp.commands.check"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="mpmpp",
        description="Model-plant mismatch detection and model diagnosis from routine closed-loop data.",
    )
    parser.add_argument("--version", action="version", version=f"mpmpp {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (help_text, module) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        importlib.import_module(module).add_arguments(p)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        return int(importlib.import_module(COMMANDS[args.command][1]).run(args) or 0)
    except (ValueError, OSError) as exc:
        print(f"mpmpp {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
