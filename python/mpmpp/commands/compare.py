"""``mpmpp compare MODEL DATA``: fit per output, residual tests, where the model fails."""
from __future__ import annotations

from ._pair import add_pair_arguments, duration, load_pair, report


def add_arguments(parser) -> None:
    add_pair_arguments(parser)
    parser.add_argument("--horizon", type=int, default=10, metavar="K",
                        help="prediction horizon k in samples for the k-step fit (default 10)")
    parser.add_argument("--max-lag", type=int, default=25, help="correlation lags -M..M (default 25)")
    parser.add_argument("--window", type=duration("--window"), metavar="DURATION",
                        help="moving-window length for the fit over time (default 1h, or a quarter "
                             "of a record shorter than 4 h)")


def run(args) -> int:
    from ..compare import compare
    from ..timeaxis import origin_of

    model, data, clock = load_pair(args)
    result = compare(model, data, horizon=args.horizon, max_lag=args.max_lag, window_s=args.window)
    return report(result, args, "compare", clock, result.summary(clock.stamp),
                  plot=lambda out: result.plot(out, origin_of(data)))
