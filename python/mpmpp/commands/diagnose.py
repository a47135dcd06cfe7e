"""``mpmpp diagnose MODEL DATA``: ranked findings (docs/formats.md ``diagnose --json``)."""
from __future__ import annotations

from ._pair import (add_pair_arguments, add_train_end_argument, load_pair, report, summary_in_data_time,
                    train_end)

# The shortest stretch diagnose fits a change on (its min_segment_s).
MONITORING_S = 3600.0


def add_arguments(parser) -> None:
    add_pair_arguments(parser)
    add_train_end_argument(parser, help_text="data before this time are taken to agree with the model")


def run(args) -> int:
    from ..diagnose import diagnose
    from ..timeaxis import origin_of

    model, data, clock = load_pair(args)
    end = train_end(args, clock, MONITORING_S, "diagnose")
    result = diagnose(model, data, train_end_s=end, min_segment_s=MONITORING_S)
    return report(result, args, "diagnose", clock, summary_in_data_time(result, clock),
                  plot=lambda out: result.plot(out, origin_of(data)))
