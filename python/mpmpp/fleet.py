"""Monitoring a plant's fleet of loops at once (``mpmpp monitor FLEET``).

A fleet is a folder with one subfolder per loop holding ``detector.json`` and ``data.csv``,
or a manifest (CSV with columns ``loop,detector,data`` and optionally ``checkpoint``, or
JSON ``{"loops": [{"loop": ..., "detector": ..., "data": ..., "checkpoint": ...}]}``;
relative paths are relative to the manifest). Each loop is monitored on its own
(``mpmpp.monitor.monitor_loop``) on all local cores or on a Dask cluster
(``mpmpp.parallel``); the rows are gathered into one table, the loops in alarm first.
"""
from __future__ import annotations

import csv
import json
import os
from pathlib import Path
from typing import Optional

from .monitor import monitor_loop
from .parallel import run_tasks

__all__ = ["load_fleet", "monitor_fleet", "format_fleet_table", "fleet_csv"]

_COLUMNS = ["loop", "status", "active", "alarms", "first_alarm", "windows", "skipped", "samples", "last_sample",
            "message"]


def _loops_of_folder(folder: Path) -> list[dict]:
    loops = []
    for sub in sorted(p for p in folder.iterdir() if p.is_dir()):
        detector, data = sub / "detector.json", sub / "data.csv"
        if detector.exists() or data.exists():
            loops.append({"loop": sub.name, "detector": str(detector), "data": str(data)})
    if not loops:
        raise ValueError(f"{folder}: no loop folders (LOOP/detector.json and LOOP/data.csv) in it")
    return loops


def _loops_of_manifest(path: Path) -> list[dict]:
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text manifest") from None
    if path.suffix.lower() == ".json":
        try:
            rows = json.loads(text)["loops"]
        except (json.JSONDecodeError, KeyError, TypeError) as exc:
            raise ValueError(f"{path}: expected {{\"loops\": [{{\"loop\", \"detector\", \"data\"}}, ...]}} ({exc})") \
                from None
    else:
        rows = list(csv.DictReader(text.splitlines()))
    loops = []
    for k, row in enumerate(rows):
        where = f"{path}: loop {k + 1}"
        if not isinstance(row, dict):
            raise ValueError(f"{where}: expected an object with loop, detector, data")
        for key in ("loop", "detector", "data"):
            if not str(row.get(key) or "").strip():
                raise ValueError(f"{where}: field '{key}' is missing or empty")
        loop = {"loop": str(row["loop"]).strip()}
        for key in ("detector", "data", "checkpoint"):
            if str(row.get(key) or "").strip():
                loop[key] = str(path.parent / str(row[key]).strip())
        loops.append(loop)
    if not loops:
        raise ValueError(f"{path}: the manifest lists no loops")
    return loops


def load_fleet(spec, checkpoints: Optional[str] = None) -> list[dict]:
    """The fleet's loops (dicts: loop, detector, data[, checkpoint]) from a folder or a
    manifest; ``checkpoints``: a folder where loops without their own checkpoint keep
    ``LOOP.checkpoint.json``."""
    path = Path(spec)
    if not path.exists():
        raise ValueError(f"{path}: no such fleet folder or manifest")
    loops = _loops_of_folder(path) if path.is_dir() else _loops_of_manifest(path)
    names = [lp["loop"] for lp in loops]
    duplicate = next((n for n in names if names.count(n) > 1), None)
    if duplicate is not None:
        raise ValueError(f"{path}: loop '{duplicate}' is listed twice")
    if checkpoints is not None:
        os.makedirs(checkpoints, exist_ok=True)
        for lp in loops:
            lp.setdefault("checkpoint", os.path.join(checkpoints, f"{lp['loop']}.checkpoint.json"))
    return loops


def monitor_fleet(spec, checkpoints: Optional[str] = None, scheduler=None, workers: Optional[int] = None,
                  progress: bool = False) -> dict:
    """Monitors every loop; returns {"loops": rows (the table), "where": ..., "counts": ...}."""
    loops = load_fleet(spec, checkpoints)
    tasks = [(lp["loop"], lp["detector"], lp["data"], lp.get("checkpoint")) for lp in loops]
    rows, where = run_tasks(monitor_loop, tasks, scheduler, workers, progress, unit="loops")
    rank = {"error": 0, "ALARM": 1, "ok": 2}
    rows.sort(key=lambda r: (rank[r["status"]], r["loop"]))
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ALARM", "ok", "error")}
    return {"loops": rows, "where": where, "counts": counts}


def _cells(row: dict) -> list[str]:
    def text(v):
        if v is None:
            return ""
        return "; ".join(v) if isinstance(v, list) else str(v)
    return [text(row.get(c)) for c in _COLUMNS]


def format_fleet_table(fleet: dict) -> str:
    """The summary table, one line per loop."""
    header = ["loop", "status", "alarm active on", "alarms", "first alarm", "windows", "skipped", "samples",
              "last sample", "message"]
    body = [_cells(r) for r in fleet["loops"]]
    widths = [max(len(h), *(len(b[i]) for b in body)) for i, h in enumerate(header)]
    line = lambda cells: "  ".join(c.ljust(w) for c, w in zip(cells, widths)).rstrip()  # noqa: E731
    c = fleet["counts"]
    return "\n".join([line(header), *(line(b) for b in body),
                      f"{len(body)} loops: {c['ALARM']} in alarm, {c['ok']} ok, {c['error']} with errors"])


def fleet_csv(fleet: dict, path) -> None:
    """The table as CSV (written atomically)."""
    from .io import atomic_output

    with atomic_output(path) as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(_COLUMNS)
        writer.writerows(_cells(r) for r in fleet["loops"])
