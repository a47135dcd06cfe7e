"""``mpmpp diagnose MODEL DATA``: ranked findings (docs/formats.md ``diagnose --json``)."""
from __future__ import annotations

from ._pair import (add_pair_arguments, add_train_end_argument, duration, load_pair, report,
                    summary_in_data_time, train_end)


def add_length_arguments(parser) -> None:
    """``--segment`` / ``--block``: the diagnosis's preferred lengths (shorter records scale them);
    ``--actuator-search``: search actuator nonlinearities with an onset on any record length."""
    parser.add_argument("--segment", type=duration("--segment"), default=None, metavar="DURATION",
                        help="shortest stretch a change is fitted on (default 1h; a record shorter than "
                             "three of them uses a third of its length)")
    parser.add_argument("--block", type=duration("--block"), default=None, metavar="DURATION",
                        help="held-out block for the cross-validation (default 1h; a record shorter than "
                             "eight of them uses an eighth of its length)")
    parser.add_argument("--actuator-search", action="store_true", default=None,
                        help="search actuator nonlinearities that set in during the record even when the "
                             "record is longer than the default budget (about a day of a 3x3 process at 5 s)")


def length_options(args) -> dict:
    """The ``diagnose`` / ``update`` keyword arguments of ``--segment`` / ``--block`` /
    ``--actuator-search``."""
    from ..diagnose.pipeline import BLOCK_S, SEGMENT_S

    return {"min_segment_s": SEGMENT_S if args.segment is None else args.segment,
            "block_s": BLOCK_S if args.block is None else args.block,
            "actuator_search": args.actuator_search}


def monitoring_s(model, data, min_segment_s: float | None = None) -> float:
    """Seconds of data diagnose needs after ``--train-end``: one segment of this record."""
    from ..diagnose.pipeline import SEGMENT_S, record_lengths

    segment = SEGMENT_S if min_segment_s is None else min_segment_s
    return record_lengths(len(data), model.sample_time_s, segment).min_segment * model.sample_time_s


def add_arguments(parser) -> None:
    add_pair_arguments(parser)
    add_train_end_argument(parser, help_text="data before this time are taken to agree with the model")
    add_length_arguments(parser)


def run(args) -> int:
    from ..diagnose import diagnose
    from ..timeaxis import origin_of

    model, data, clock = load_pair(args)
    lengths = length_options(args)
    end = train_end(args, clock, monitoring_s(model, data, lengths["min_segment_s"]), "diagnose")
    result = diagnose(model, data, train_end_s=end, **lengths)
    return report(result, args, "diagnose", clock, summary_in_data_time(result, clock),
                  plot=lambda out: result.plot(out, origin_of(data)))
