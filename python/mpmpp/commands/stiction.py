"""``mpmpp stiction DATA --op COL --pv COL [--sp COL]``: valve stiction from one PI loop's
routine data, by mpmpp's closed-loop Hammerstein fit, with the literature baselines beside it."""
from __future__ import annotations

import json

import numpy as np

from ..signals import complete_segments, longest, missing_counts
from ..stiction.hammerstein import HYSTERESIS_KINDS
from ..timeaxis import sample_grid, seconds_of

# a stretch shorter than this adds a valve start from rest and little else
MIN_STRETCH = 30


def add_arguments(parser) -> None:
    from ._pair import DATA_HELP, add_data_arguments

    parser.add_argument("data", metavar="DATA", help=DATA_HELP)
    parser.add_argument("--op", required=True, metavar="COL", help="controller output column")
    parser.add_argument("--pv", required=True, metavar="COL", help="process variable column")
    parser.add_argument("--sp", metavar="COL", help="setpoint column (optional)")
    parser.add_argument("--json", action="store_true", help="print one JSON document")
    add_data_arguments(parser)


def _column(df, name: str, path: str) -> np.ndarray:
    if name not in df.columns or name == "time":
        columns = ", ".join(c for c in df.columns if c != "time")
        raise ValueError(f"{path}: no column '{name}' (columns: {columns})")
    values = df[name].to_numpy(dtype=float)
    if not np.isfinite(values).any():
        raise ValueError(f"{path}: column '{name}' has no values")
    return values


def _stretches(df, names: list[str], columns: list[np.ndarray], path: str) -> tuple[list, str | None]:
    """The stretches of rows with every column present and no time gap inside (the fit runs the
    valve through consecutive samples, restarting at each), and a note when rows were left out."""
    try:
        _, starts = sample_grid(seconds_of(df), df.attrs.get("segment_starts", ()))
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    try:
        runs, skipped = complete_segments(np.all(np.isfinite(np.column_stack(columns)), axis=1), MIN_STRETCH, starts)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc} ({missing_counts(names, np.column_stack(columns))})") from None
    if not skipped:
        return runs, None
    a, b = longest(runs)
    return runs, (f"{skipped} rows skipped (missing values, time gaps, stretches under {MIN_STRETCH} rows); "
                  f"the valve fit uses {len(runs)} stretch(es), {len(df) - skipped} rows; the baselines the longest, "
                  f"rows {a}-{b - 1}")


def _plain(value):
    return float(value) if isinstance(value, (float, np.floating)) else value


def run(args) -> int:
    from ._pair import load_loop_data_for, note_repairs
    from ..stiction import analyse_loop

    df = load_loop_data_for(args, [c for c in (args.op, args.pv, args.sp) if c])
    note_repairs(args.data, df.attrs["repairs"])
    names = [c for c in (args.op, args.pv, args.sp) if c]
    columns = [_column(df, c, args.data) for c in names]
    stretches, skipped = _stretches(df, names, columns, args.data)
    op, pv, *sp = columns
    sp = sp[0] if sp else None
    rows = sum(b - a for a, b in stretches)
    try:
        report = analyse_loop(op, pv, sp, names=(f"OP '{args.op}'", f"PV '{args.pv}'"), stretches=stretches)
    except ValueError as exc:
        raise ValueError(f"{args.data}: {exc}") from None
    if skipped:
        report.notes.insert(0, skipped)
    h = report.mpmpp
    if args.json:
        print(json.dumps({
            "samples": rows,
            "mpmpp": {"stiction": h.verdict, "kind": h.kind,
                      "size": {k: _plain(v) for k, v in h.params.items()},
                      "confidence": h.confidence, "gain_per_sample": h.gain_per_sample,
                      "oscillating_disturbance_period_samples": h.disturbance_period},
            "baselines": {name: {"stiction": verdict, **{k: _plain(v) for k, v in details.items()}}
                          for name, (verdict, details) in report.baselines.items()},
            "notes": report.notes,
        }, indent=2))
        return 0
    print(f"{args.data}: {rows} samples, OP '{args.op}', PV '{args.pv}'"
          + (f", SP '{args.sp}'" if args.sp else ""))
    if h.verdict:
        print(f"mpmpp: STICTION ({h.kind}: {h.size_text()} in OP units), confidence {h.confidence:.2f}")
    elif h.kind in HYSTERESIS_KINDS:
        # a valve that fits, but on an OP held to its rate limit, which a sticking valve mimics
        print(f"mpmpp: no stiction verdict: the best fit is {h.kind} ({h.size_text()}), but the OP is held to "
              f"a rate limit in most of its moves (see the note); the fit alone would say {h.confidence:.2f}")
    elif h.kind != "linear":
        print(f"mpmpp: no stiction: a static {h.kind} ({h.size_text()}) explains the data better than a sticking "
              f"valve" + (f" (the valve alone would say {h.confidence:.2f})" if h.confidence > 0.5
                          else f"; stiction confidence {h.confidence:.2f}"))
    else:
        print(f"mpmpp: no actuator nonlinearity found, stiction confidence {h.confidence:.2f}")
    print(f"  held-out log-likelihood gain of the best stick-slip valve over a linear one: "
          f"{h.gain_per_sample:.4f} per sample")
    if h.disturbance_period is not None:
        print(f"  the loop oscillates regularly with a period of {h.disturbance_period:.1f} samples, which a linear "
              f"valve with an oscillating disturbance predicts better than without it")
    for note in report.notes:
        print(f"note: {note}")
    print("baselines:")
    for name, (verdict, details) in report.baselines.items():
        if verdict is None:
            print(f"  {name:12s} not run: {details['not_run']}")
            continue
        text = ", ".join(f"{k} {v:.3g}" for k, v in details.items())
        print(f"  {name:12s} {'stiction' if verdict else 'no':9s} {text}")
    return 0
