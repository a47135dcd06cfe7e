"""The ``mpmpp`` command line (contract: docs/formats.md).

Each subcommand lives in its own module under ``mpmpp.commands`` exposing
``add_arguments(parser)`` and ``run(args) -> int``. Only the module of the command being
run is imported (and nothing heavy for ``mpmpp --help``), so the command line answers at
once; the engine, NumPy, pandas and matplotlib load when a command needs them.
Bad input (ValueError, OSError on the user's files) becomes one line on stderr
and exit code 2, never a traceback.
"""
from __future__ import annotations

import argparse
import importlib
import os
import sys


# name -> (one-line help, module implementing it)
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("reproduce the paper's example end to end (simulate, detect, plot)", "mpmpp.commands.demo"),
    "simulate": ("closed-loop simulation with MPC and scheduled plant/noise changes", "mpmpp.commands.simulate"),
    "evaluate": ("Monte Carlo: detection and false-alarm rates, delays, against baselines", "mpmpp.commands.evaluate"),
    "compare": ("model vs measurements: fit per output, residual tests, where it fails", "mpmpp.commands.compare"),
    "detect": ("moving-window MPM and noise-change detection per channel", "mpmpp.commands.detect"),
    "diagnose": ("ranked findings: which physical effect is missing, where, when", "mpmpp.commands.diagnose"),
    "update": ("add/refit the effect(s), write the new model, print error before and after", "mpmpp.commands.update"),
    "identify": ("a model file from routine closed-loop data: gain, time constant, dead time", "mpmpp.commands.identify"),
    "monitor": ("new data through a saved detector: one loop (resumable) or a fleet of loops", "mpmpp.commands.monitor"),
    "report": ("one self-contained HTML page: data, compare, diagnose, update, detect", "mpmpp.commands.report"),
    "stiction": ("valve stiction in a PI loop from OP and PV, with the literature tests beside it", "mpmpp.commands.stiction"),
    "check": ("validate a model file (and a data file against it) and summarise them", "mpmpp.commands.check"),
}


class _Version(argparse.Action):
    """--version, reading the engine's version only when asked."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, help="show the version and exit")

    def __call__(self, parser, namespace, values, option_string=None):
        from ._core import __version__

        print(f"mpmpp {__version__}")
        parser.exit()


def _named_command(argv: list[str]) -> str | None:
    """The subcommand in ``argv``: the first argument that is not an option."""
    for arg in argv:
        if not arg.startswith("-"):
            return arg if arg in COMMANDS else None
    return None


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser; only the subcommand named in ``argv`` gets its arguments (all of them when
    ``argv`` is None), the others are listed by name and help text."""
    parser = argparse.ArgumentParser(
        prog="mpmpp",
        description="Model-plant mismatch detection and model diagnosis from routine closed-loop data. "
                    "File formats: docs/formats.md in the repository.",
    )
    parser.add_argument("--version", action=_Version)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    wanted = None if argv is None else _named_command(argv)
    for name, (help_text, module) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        if argv is None or name == wanted:
            importlib.import_module(module).add_arguments(p)
    parser.commands = sub.choices   # name -> its parser, whose usage an error on its arguments shows
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    args, unknown = parser.parse_known_args(argv)
    if unknown:   # named by the command's parser: "mpmpp simulate: error: ...", with its usage
        parser.commands.get(args.command, parser).error(f"unrecognized arguments: {' '.join(unknown)}")
    if args.command is None:
        parser.print_help()
        return 2
    # The commands' NumPy work is many small least-squares solves (valve fits, trend scans):
    # threaded BLAS spends more on its threads than on them, 20x on a loaded 2-core machine
    # (docs/diagnose.md). One thread unless the user set otherwise; studies and fleets
    # parallelise over processes.
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    try:
        return int(importlib.import_module(COMMANDS[args.command][1]).run(args) or 0)
    except (ValueError, OSError) as exc:
        print(f"mpmpp {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
