"""What the analysis commands share: reading the model + data pair (with the historian
repairs), the data's clock, ``--train-end``, and writing the result."""
from __future__ import annotations

import sys

DATA_HELP = "operating data (CSV, docs/formats.md; historian exports: docs/files.md)"


def duration(option: str):
    """An argparse type for a duration option (``90min``, ``6h``, ``3600``)."""
    def parse(text):
        import argparse

        from ..clock import parse_duration

        try:
            return parse_duration(text, option)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return parse


def add_data_arguments(parser) -> None:
    """How a historian export is put on the model's sample grid (docs/files.md "Historian exports")."""
    g = parser.add_argument_group("historian data")
    g.add_argument("--max-gap", type=duration("--max-gap"), metavar="DURATION",
                   help="gaps up to this long (time between the samples around them) become missing rows, "
                        "longer ones split the record into segments (default: 10 sample times)")
    g.add_argument("--resample", type=duration("--resample"), metavar="DURATION",
                   help="block-average data sampled faster than the model to its sample time (e.g. 5s; "
                        "identify and stiction: to this sample time)")
    g.add_argument("--quality-column", metavar="COL",
                   help="status column: rows whose quality is not good become missing values")
    g.add_argument("--good-quality", metavar="CODE[,CODE...]",
                   help="the good codes of --quality-column (default for text codes: those starting with "
                        "'good'; required for numeric codes, e.g. 192 for OPC DA)")


def add_pair_arguments(parser, outputs: bool = True) -> None:
    parser.add_argument("model", metavar="MODEL", help="nominal model file (JSON, docs/formats.md)")
    parser.add_argument("data", metavar="DATA", help=DATA_HELP)
    if outputs:
        parser.add_argument("--out", metavar="DIR", help="write PNG figures and tables here")
        parser.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    add_data_arguments(parser)


def add_train_end_argument(parser, required: bool = False, help_text: str = "") -> None:
    parser.add_argument("--train-end", required=required, metavar="WHEN",
                        help=(help_text + "; " if help_text else "") +
                        "a duration from the first sample (6h, 90min, 3600 = seconds) or a timestamp "
                        "(2026-03-01T14:00:00+01:00)")


def _historian_options(args) -> dict:
    good = [c.strip() for c in args.good_quality.split(",") if c.strip()] if args.good_quality else []
    if good and not args.quality_column:
        raise ValueError("--good-quality needs --quality-column")
    return {"max_gap_s": args.max_gap, "resample_s": args.resample, "quality_column": args.quality_column,
            "good_quality": good}


def load_data_for(model, args):
    """The data file of ``args`` on ``model``'s grid, with the historian options."""
    from ..io import load_data

    return load_data(args.data, model, **_historian_options(args))


def load_loop_data_for(args, columns):
    """The data file of ``args`` on its own sample grid (no model yet: ``identify``,
    ``stiction``), with the historian options; ``columns`` must be numeric."""
    from ..io import load_loop_data

    return load_loop_data(args.data, columns, **_historian_options(args))


def load_pair(args):
    """(model, data, clock) of a command's MODEL and DATA arguments."""
    from ..clock import Clock
    from ..io import load_model

    model = load_model(args.model)
    data = load_data_for(model, args)
    note_repairs(args.data, data.attrs["repairs"], "(details: mpmpp check)")
    return model, data, Clock.of(data, model.sample_time_s)


def note_repairs(path, repairs: dict, details: str = "") -> None:
    """One ``note:`` line on stderr naming every repair of DATA (none: nothing printed)."""
    lines = repair_lines(repairs)
    if lines:
        print(f"note: {path}: {'; '.join(lines)}{' ' + details if details else ''}", file=sys.stderr)


def repair_lines(r: dict, shown_gaps: int = 0) -> list[str]:
    """Every repair of a historian export (``load_data``'s ``repairs``), one line each; gaps
    beyond the first ``shown_gaps`` are counted together."""
    lines = []
    if r["resample_factor"] > 1:
        lines.append(f"blocks of {r['resample_factor']} samples of {r['raw_sample_time_s']:g} s averaged "
                     "into one (a block with a missing value is missing)")
    if r["jitter_snapped"]:
        lines.append(f"{r['jitter_snapped']} timestamp(s) snapped to the sample grid "
                     f"(largest move {r['max_jitter_s']:.3g} s)")
    if r["duplicates_dropped"]:
        lines.append(f"{r['duplicates_dropped']} repeated row(s) dropped (same time, same values)")
    if r["bad_quality_rows"]:
        lines.append(f"{r['bad_quality_rows']} row(s) of bad quality made missing")
    for g in r["gaps"][:shown_gaps]:
        start, end = g.get("start", f"{g['start_s']:g} s"), g.get("end", f"{g['end_s']:g} s")
        what = "record split, a new segment starts" if g["split"] else f"{g['missing_rows']} missing row(s) added"
        lines.append(f"gap {start} .. {end} ({g['end_s'] - g['start_s']:g} s between samples): {what}")
    rest = r["gaps"][shown_gaps:]
    more = "more " if shown_gaps else ""
    bridged = [g["missing_rows"] for g in rest if not g["split"]]
    if bridged:
        lines.append(f"{len(bridged)} {more}gap(s) filled with {sum(bridged)} missing row(s)")
    if len(rest) > len(bridged):
        lines.append(f"{len(rest) - len(bridged)} {more}gap(s) longer than --max-gap split the record")
    for w in r["status_words"]:
        lines.append(f"column {w['column']}: {w['cells']} status word(s) read as missing (the first {w['first']!r})")
    if r["text_columns"]:
        lines.append(f"text column(s) ignored (no numbers): {', '.join(r['text_columns'])}")
    return lines


def train_end(args, clock, after_s: float, needed_for: str):
    """``--train-end`` on the data's time axis (None when not given). It must leave at least
    ``after_s`` seconds of data after it: ``needed_for`` says what they are needed for."""
    if args.train_end is None:
        return None
    t = clock.when(args.train_end)
    left = clock.end_s + clock.sample_time_s - t
    if left < after_s:
        raise ValueError(f"--train-end {args.train_end} leaves {left / 3600:.3g} h of data after it; "
                         f"{needed_for} needs at least {after_s / 3600:.3g} h ({clock.source} spans {clock.span()})")
    return t


def result_document(result, clock) -> dict:
    """A result's JSON document with the data's time: a ``time`` block and a timestamp
    beside each point in time."""
    return {**clock.stamp_fields(result.to_dict()), "time": clock.to_dict()}


def report(result, args, name: str, clock, summary: str, plot=None) -> int:
    """The shared output of the pair commands: ``--out DIR`` gets the figures (``plot(dir)``,
    default ``result.plot``) and ``NAME.json`` (written atomically), stdout gets the JSON
    document (``--json``) or the ``summary``."""
    import json
    from pathlib import Path

    from ..io import atomic_output

    doc = result_document(result, clock)
    if args.out:
        Path(args.out).mkdir(parents=True, exist_ok=True)
        paths = (plot or result.plot)(args.out)
        with atomic_output(Path(args.out) / f"{name}.json") as f:
            f.write(json.dumps(doc, indent=1))
    if args.json:
        print(json.dumps(doc))
    else:
        print(summary)
        if args.out:
            print(f"  figures: {', '.join(str(p) for p in paths)}")
    return 0


def summary_in_data_time(result, clock) -> str:
    """A diagnose/update summary with its onsets in the data's time: the library writes an
    onset as ``t=<hours of the time column> h``; each becomes a timestamp (calendar time) or
    hours since the first sample."""
    text = result.summary()
    for t in sorted(set(_onsets(result.to_dict())), reverse=True):
        shown = clock.stamp(t) if clock.calendar else f"t={clock.hours(t)}"
        text = text.replace(f"t={t / 3600:.1f} h", shown)
    return text


def _onsets(doc):
    if isinstance(doc, dict):
        for key, value in doc.items():
            if key == "onset_s" and isinstance(value, (int, float)):
                yield float(value)
            else:
                yield from _onsets(value)
    elif isinstance(doc, list):
        for x in doc:
            yield from _onsets(x)
