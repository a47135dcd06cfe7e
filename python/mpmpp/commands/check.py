"""``mpmpp check MODEL [DATA]``: validate the user's files and summarise them.

The first thing to run on a new pair of files: every problem is reported as one
line naming the file and the field, column or row (exit code 2).
"""
from __future__ import annotations

import argparse
import json

import numpy as np

from ..held_values import frozen_columns, held_columns
from ._pair import add_data_arguments, load_data_for, repair_lines


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", metavar="MODEL", help="model file (JSON, docs/formats.md 'Model file')")
    parser.add_argument("data", metavar="DATA", nargs="?", help="data file (CSV) to check against the model")
    parser.add_argument("--detail", action="store_true",
                        help="also show each channel as its discrete transfer function in q^-1")
    parser.add_argument("--json", action="store_true", help="print one JSON document instead of the summary")
    add_data_arguments(parser)


def _finite_or_none(x: float):
    """JSON has no infinity: an integrating channel's dc gain is reported as null."""
    return x if np.isfinite(x) else None


def _model_summary(path: str, model) -> dict:
    from ..foptd import foptd_parameters, integrating_parameters

    channels = []
    for output, input_ in model.channels():
        g = model.process(output, input_)
        f = foptd_parameters(g, model.sample_time_s)
        r = integrating_parameters(g, model.sample_time_s) if f is None else None
        channels.append({"output": output, "input": input_, "num": g.num.tolist(), "den": g.den.tolist(),
                         "delay": g.delay, "dc_gain": _finite_or_none(g.dc_gain()), "text": str(g),
                         "foptd": None if f is None else {"gain": f.gain, "time_constant_s": f.time_constant_s,
                                                          "dead_time_s": f.dead_time_s, "exact": f.exact},
                         "integrating": None if r is None else {"rate_gain_per_s": r.rate_gain,
                                                                "time_constant_s": r.time_constant_s,
                                                                "dead_time_s": r.dead_time_s},
                         "foptd_text": str(f) if f is not None else str(r) if r is not None else None})
    noise = []
    for output in model.outputs:
        h = model.noise(output)
        noise.append({"output": output, "num": h.num.tolist(), "den": h.den.tolist(), "text": str(h)})
    return {"path": path, "name": model.name, "sample_time_s": model.sample_time_s,
            "inputs": list(model.inputs), "outputs": list(model.outputs), "channels": channels, "noise": noise}


def _data_summary(path: str, df, model) -> dict:
    from ..clock import Clock

    time = df["time"].to_numpy()
    clock = Clock.of(df, model.sample_time_s)
    modelled = [*model.inputs, *model.outputs]
    others = [c for c in df.columns if c != "time" and c not in modelled]
    setpoints = [c for c in others if c.endswith("_sp") and c[:-3] in model.outputs]
    return {
        "path": path,
        "samples": int(len(df)),
        "start_s": float(time[0]),
        "end_s": float(time[-1]),
        # Each sample stands for one sample interval, so n samples span n * Ts.
        "duration_s": float(len(df) * model.sample_time_s),
        "time_origin": df.attrs["time_origin"],
        "time": clock.to_dict(),
        "span": clock.span(),
        "segments": len(df.attrs["segment_starts"]) + 1,
        "repairs": clock.stamp_fields(df.attrs["repairs"]),
        "columns": [c for c in df.columns if c != "time"],
        "missing": {c: int(n) for c, n in df.attrs["missing"].items()},
        "setpoints": setpoints,
        "candidates": [c for c in others if c not in setpoints],
        "rows_with_missing": int(np.isnan(df.drop(columns="time").to_numpy()).any(axis=1).sum()),
        "frozen": {c: float(df[c].dropna().iloc[0]) for c in frozen_columns(modelled, df[modelled])},
        "held": clock.stamp_fields(_held(df, modelled, model.sample_time_s)),
        "interpolated": _interpolated(df, model),
    }


def _held(df, columns: list, sample_time_s: float) -> dict:
    """Model column -> the stretches of an hour or more (held_values.HELD_STRETCH_S) over which it holds one value
    (columns frozen throughout, or with no such stretch, left out)."""
    time = df["time"].to_numpy(dtype=float)
    return {c: [{"start_s": float(time[a]), "end_s": float(time[b - 1])} for a, b in stretches]
            for c, stretches in held_columns(columns, df[columns], sample_time_s).items()}


def _when(doc: dict, key: str) -> str:
    """A point in time of a document: its calendar stamp, or hours of the time column."""
    return doc.get(key, f"{doc[key + '_s'] / 3600:.2f} h")


def _interpolated(df, model) -> dict:
    """Output -> lost samples compare, diagnose and identify interpolate rather than cut the
    record at (signals.bridge_lost_outputs), outputs with none left out."""
    from ..signals import bridge_lost_outputs

    _, filled = bridge_lost_outputs(df[list(model.outputs)].to_numpy(dtype=float),
                                    df[list(model.inputs)].to_numpy(dtype=float), df.attrs["segment_starts"])
    return {o: int(n) for o, n in zip(model.outputs, filled.sum(axis=0)) if n}


def _channel_line(ch: dict) -> str:
    if ch["foptd_text"] is not None:
        return ch["foptd_text"]
    if ch["dc_gain"] is None:
        return "integrating (infinite dc gain), no first-order reading"
    return (f"dc gain {ch['dc_gain']:.6g}, no first-order or integrating reading (unstable, zero gain, or a "
            "pole at 1 within rounding)")


def _print_summary(report: dict, detail: bool) -> None:
    m = report["model"]
    print(f"model {m['path']}: '{m['name']}', {len(m['inputs'])} input(s), {len(m['outputs'])} output(s), "
          f"sample time {m['sample_time_s']:g} s")
    print(f"  inputs: {', '.join(m['inputs'])}; outputs: {', '.join(m['outputs'])}")
    for ch in m["channels"]:
        print(f"  channel {ch['output']} <- {ch['input']}: {_channel_line(ch)}")
        if detail:
            print(f"    in q^-1: {ch['text']}")
    if not m["channels"]:
        print("  no process channels (the model claims no coupling at all)")
    for h in m["noise"]:
        print(f"  noise {h['output']}: {h['text']}")
    d = report.get("data")
    if d is None:
        return
    print(f"data {d['path']}: {d['samples']} samples, {d['span']}"
          + (f", {d['segments']} segments" if d["segments"] > 1 else ""))
    for line in repair_lines(d["repairs"], shown_gaps=10):
        print(f"  repaired: {line}")
    if d["frozen"]:
        listed = ", ".join(f"{c} = {v:g}" for c, v in d["frozen"].items())
        print(f"  one value throughout (a frozen tag or a stuck signal; no channel through it can be checked): "
              f"{listed}")
    for c, stretches in d["held"].items():
        shown = ", ".join(f"{_when(s, 'start')} .. {_when(s, 'end')}" for s in stretches)
        print(f"  {c} holds one value for an hour or more (at a limit, in manual, stuck or a stale tag): {shown}")
    if d["setpoints"]:
        print(f"  setpoints: {', '.join(d['setpoints'])}")
    if d["candidates"]:
        print(f"  other measured columns (candidates for diagnose): {', '.join(d['candidates'])}")
    missing = {c: n for c, n in d["missing"].items() if n}
    if missing:
        listed = ", ".join(f"{c} {n}" for c, n in missing.items())
        print(f"  missing values: {listed} ({d['rows_with_missing']} rows affected)")
        if d["interpolated"]:
            bridged = ", ".join(f"{o} {n}" for o, n in d["interpolated"].items())
            print(f"  interpolated by compare, diagnose and identify (runs of at most 2, at most 1 % of an "
                  f"output's rows): {bridged}; the other missing values end a data segment")
    else:
        print("  missing values: none")


def run(args: argparse.Namespace) -> int:
    from ..io import load_model

    model = load_model(args.model)
    report = {"model": _model_summary(args.model, model)}
    if args.data is not None:
        report["data"] = _data_summary(args.data, load_data_for(model, args), model)
    if args.json:
        print(json.dumps(report, indent=2))
    else:
        _print_summary(report, args.detail)
    return 0
