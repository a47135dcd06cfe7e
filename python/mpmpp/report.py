"""One HTML page a control engineer can send a colleague (``mpmpp report``).

``build_report(model, data)`` runs the whole analysis on one model + data pair and returns a
self-contained page: figures embedded as base64 PNG, styles inline, nothing fetched from a
network. Sections: the data (summary, missing values, repairs), compare (how well the model
predicts), diagnose (findings, prediction before and after applying them), update (the fall
of the held-out prediction error) and detect (the alarm timeline). A section that cannot be
computed on this data says why in place, so the rest of the page is still useful.
"""
from __future__ import annotations

import base64
import datetime
import html
import os
import tempfile
from pathlib import Path
from typing import Optional

import numpy as np

from . import __version__
from .clock import Clock
from .timeaxis import format_duration, origin_of

__all__ = ["build_report", "write_report"]

_STYLE = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Arial,sans-serif;margin:0;color:#1d2330;background:#fff}
main{max-width:1180px;margin:0 auto;padding:24px 28px 60px}
h1{font-size:26px;margin:0 0 4px}h2{font-size:20px;margin:34px 0 8px;border-bottom:2px solid #d8dee9;padding-bottom:4px}
h3{font-size:15px;margin:18px 0 6px}.meta{color:#56607a;font-size:13px}
table{border-collapse:collapse;margin:8px 0 12px;font-size:13px}
th,td{border:1px solid #d8dee9;padding:4px 9px;text-align:left;vertical-align:top}th{background:#f1f4f9}
td.num{text-align:right;font-variant-numeric:tabular-nums}
img{max-width:100%;height:auto;display:block;margin:8px 0 14px;border:1px solid #eef1f6}
.note{background:#fff8e6;border-left:4px solid #f0b429;padding:8px 12px;font-size:13px}
.ok{color:#1a7f37;font-weight:600}.bad{color:#c62828;font-weight:600}
nav a{margin-right:14px;font-size:14px}
"""

# Marks the page as fully loaded once every embedded figure has decoded (checked by tests
# in a headless browser: a corrupt figure leaves data-figures="broken N").
_SCRIPT = """
window.addEventListener("load", function () {
  var imgs = Array.prototype.slice.call(document.images);
  var broken = imgs.filter(function (i) { return !(i.complete && i.naturalWidth > 0); }).length;
  document.body.setAttribute("data-figures", broken ? "broken " + broken : "ok " + imgs.length);
});
"""


class _Page:
    def __init__(self):
        self.parts: list[str] = []

    def add(self, text: str) -> None:
        self.parts.append(text)

    def heading(self, level: int, text: str, anchor: Optional[str] = None) -> None:
        ident = f' id="{anchor}"' if anchor else ""
        self.add(f"<h{level}{ident}>{html.escape(text)}</h{level}>")

    def para(self, text: str, cls: Optional[str] = None) -> None:
        self.add(f'<p class="{cls}">{html.escape(text)}</p>' if cls else f"<p>{html.escape(text)}</p>")

    def table(self, header: Optional[list], rows: list) -> None:
        def cell(v, tag="td"):
            if isinstance(v, (int, float, np.floating)) and not isinstance(v, bool):
                return f'<{tag} class="num">{html.escape(_number(v))}</{tag}>'
            return f"<{tag}>{html.escape(str(v))}</{tag}>"
        head = "<tr>" + "".join(cell(h, "th") for h in header) + "</tr>" if header else ""
        self.add("<table>" + head
                 + "".join("<tr>" + "".join(cell(v) for v in r) + "</tr>" for r in rows) + "</table>")

    def figure(self, png: bytes, alt: str) -> None:
        data = base64.b64encode(png).decode("ascii")
        self.add(f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">')

    def figure_file(self, path, alt: str) -> None:
        self.figure(Path(path).read_bytes(), alt)


def _number(v) -> str:
    v = float(v)
    if not np.isfinite(v):
        return "n/a"
    return f"{v:.4g}" if v != int(v) or abs(v) >= 1e6 else f"{int(v)}"


def _section(page: _Page, title: str, anchor: str, body, *args) -> None:
    """A section whose analysis may not apply to this data: its error is shown in place."""
    page.heading(2, title, anchor)
    try:
        body(page, *args)
    except (ValueError, OSError) as exc:
        page.para(f"Not available for this data: {exc}", "note")


def _data_section(page: _Page, model, data, clock, origin, data_path: str) -> None:
    time_s = data["time"].to_numpy(float)
    ts = model.sample_time_s
    rows = [["model", f"{model.name} ({len(model.inputs)} input(s), {len(model.outputs)} output(s))"],
            ["inputs (manipulated)", ", ".join(model.inputs)], ["outputs (controlled)", ", ".join(model.outputs)],
            ["data file", data_path], ["samples", len(data)], ["sample time", format_duration(ts)],
            ["from", clock.stamp(time_s[0])], ["to", clock.stamp(time_s[-1])],
            ["span", format_duration(len(data) * ts)]]
    page.table(None, rows)
    missing = data.attrs.get("missing", {})
    page.heading(3, "Columns")
    page.table(["column", "role", "missing values"],
               [[c, "input" if c in model.inputs else "output" if c in model.outputs else "other",
                 int(missing.get(c, 0))]
                for c in data.columns if c != "time"])
    repairs = data.attrs.get("repairs") or []
    page.heading(3, "Repairs made while reading")
    if repairs:
        page.add("<ul>" + "".join(f"<li>{html.escape(str(r))}</li>" for r in repairs) + "</ul>")
    else:
        page.para("None: the file was used exactly as written (missing cells stay missing, nothing interpolated).")
    from .detect_plots import plot_profiles

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "profiles.png")
        plot_profiles(model, data, path, origin=origin)
        page.figure_file(path, "signals over time")


def _compare_section(page: _Page, model, data, clock, origin) -> None:
    from .compare import compare
    from .compare_plots import plot_compare

    result = compare(model, data)
    page.para(f"How well the model predicts each output from the measured inputs. A fit of 100 % is perfect, "
              f"0 % is no better than the mean. Prediction {result.horizon} samples "
              f"({format_duration(result.horizon * model.sample_time_s)}) ahead.")
    page.table(["output", "fit, inputs only", f"fit, {result.horizon} samples ahead", "one-step error (RMS)",
                "error white?", "where it fails", "valve hysteresis"],
               [[oc.output, f"{oc.fit_simulation:.1f} %", f"{oc.fit_prediction:.1f} %", oc.rms_prediction_error,
                 "yes" if not oc.whiteness.positive_lag_violations else "no",
                 "; ".join(f"{clock.stamp(p.start_s)} to {clock.stamp(p.end_s)}" for p in oc.failing)
                 or "nowhere",
                 "; ".join(f"{h.column}: a play of about {h.width:.3g} explains {100 * h.explained:.0f} %"
                           for h in oc.hysteresis if h.significant) or "not seen"]
                for oc in result.outputs])
    for note in result.disturbance:   # the errors above are through a disturbance model estimated from the data
        page.para(note, cls="note")
    with tempfile.TemporaryDirectory() as tmp:
        for path in plot_compare(result, Path(tmp), origin):
            if path.name.endswith(("_prediction.png", "_fit_over_time.png")):
                page.figure_file(path, path.stem)


def _diagnose_section(page: _Page, model, data, clock, origin, train_end_s) -> Optional[object]:
    """Findings, and the model with all of them applied (the UpdateResult, for the next section)."""
    from .compare import compare
    from .diagnose import diagnose
    from .report_plots import plot_before_after
    from .update import update

    result = diagnose(model, data, train_end_s=train_end_s)
    if not result.findings:
        page.para("No finding: the model is consistent with the data.", "ok")
        return None
    page.table(["id", "effect", "where", "starts", "confidence", "error before", "error after", "explanation"],
               [[f.id, f.effect.replace("_", " "), " \u2190 ".join(x for x in (f.output, f.input) if x) or "all",
                 clock.stamp(f.onset_s), f"{f.confidence:.2f}",
                 f.error_before, f.error_after, f.explanation] for f in result.findings])
    page.para(f"Error: {result.metric}.", "meta")
    ids = [f.id for f in result.findings]
    updated = update(model, data, ids, train_end_s=train_end_s)
    page.heading(3, f"Predictions before and after applying {', '.join(ids)}")
    before, after = compare(model, data), compare(updated.model, data)
    onsets = {}
    for f in result.findings:
        for out in ([f.output] if f.output else list(model.outputs)):
            onsets.setdefault(out, []).append((f.onset_s, f.id))
    for ob, oa in zip(before.outputs, after.outputs):
        if ob.output not in onsets:  # no finding on it: the update leaves its prediction as it was
            continue
        page.figure(plot_before_after(ob.output, ob.time_s, ob.measured, ob.predicted, oa.predicted, ob.horizon,
                                      onsets.get(ob.output, []), origin), f"{ob.output} before and after")
    return updated


def _update_section(page: _Page, updated) -> None:
    from .report_plots import plot_error_fall

    if updated is None:
        page.para("Nothing to update: diagnose found no change to make.")
        return
    page.para(f"Applied {', '.join(updated.applied)}. Error: {updated.metric}.")
    for caution in updated.cautions:
        page.para(f"Caution: {caution}.", cls="note")
    page.table(["output", "error before", "error after", "change"],
               [[e.output, e.error_before, e.error_after,
                 f"{100 * (e.error_after / e.error_before - 1):+.1f} %" if e.error_before else "n/a"]
                for e in updated.errors])
    page.figure(plot_error_fall(updated.errors), "prediction error before and after the update")


def _detect_section(page: _Page, model, data, clock, origin, train_end_s, config) -> None:
    from .detect import channel_label, detect
    from .detect_plots import plot_detection
    from .noise_alarm_check import unexplained_noise_alarms
    from .report_plots import plot_alarm_timeline

    result = detect(model, data, train_end_s, config)
    page.para(f"The detector learnt the model's behaviour in the first {format_duration(result.train_end_s)} "
              f"(shaded), then checked every moving window. An alarm starts when at least "
              f"{100 * result.threshold:g} % of the recent windows look unlike the training period.")
    rows = [[channel_label(a), "model-plant mismatch" if a["kind"] == "process" else "disturbance change",
             clock.stamp(a["start_s"])] for a in result.alarms]
    if rows:
        page.table(["channel", "alarm", "starts"], rows)
    else:
        page.para("No alarm.", "ok")
    for output in unexplained_noise_alarms(result):
        page.para(f"{output}'s disturbance-change alarm has no model-plant mismatch alarm beside it. In closed "
                  "loop a process change can read as a disturbance change; the Diagnose section above says "
                  "whether the whole record shows one.", "note")
    page.figure(plot_alarm_timeline(result, origin), "alarm timeline")
    with tempfile.TemporaryDirectory() as tmp:
        for kind in ("process", "noise"):
            path = os.path.join(tmp, f"{kind}.png")
            plot_detection(result, path, kinds=(kind,), origin=origin,
                           title="Model-plant mismatch, per process channel" if kind == "process"
                           else "Disturbance changes, per output")
            page.figure_file(path, f"{kind} detection")


def build_report(model, data, model_path, data_path, train_end_s: Optional[float] = None, config=None) -> str:
    """The report page (HTML text) for ``model`` and ``data`` as read from ``model_path`` and
    ``data_path`` (named on the page)."""
    # Times in text as every command writes them (Clock.stamp); figure axes from the origin.
    clock, origin = Clock.of(data, model.sample_time_s), origin_of(data)
    # detect counts its training from the first sample; diagnose reads the time column itself.
    on_time_axis = None if train_end_s is None else float(data["time"].iloc[0]) + train_end_s
    page = _Page()
    created = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    page.add(f"<h1>{html.escape(str(model.name))}: model check</h1>")
    page.para(f"{os.fspath(model_path)} against {os.fspath(data_path)}; mpmpp {__version__}, {created}", "meta")
    page.add('<nav><a href="#data">Data</a><a href="#compare">Compare</a><a href="#diagnose">Diagnose</a>'
             '<a href="#update">Update</a><a href="#detect">Detect</a></nav>')
    _section(page, "Data", "data", _data_section, model, data, clock, origin, os.fspath(data_path))
    _section(page, "Compare: does the model predict the data?", "compare", _compare_section, model, data, clock, origin)
    holder = {}
    _section(page, "Diagnose: what changed, where, when", "diagnose",
             lambda p: holder.update(updated=_diagnose_section(p, model, data, clock, origin, on_time_axis)))
    _section(page, "Update: how much the findings reduce the error", "update",
             lambda p: _update_section(p, holder.get("updated")) if "updated" in holder else
             p.para("Not available: diagnose did not complete.", "note"))
    _section(page, "Detect: alarms over time", "detect", _detect_section, model, data, clock, origin, train_end_s, config)
    title = html.escape(f"{model.name}: model check")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{title}</title><link rel=\"icon\" href=\"data:,\">"
            f"<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><style>{_STYLE}</style>"
            f"<script>{_SCRIPT}</script></head><body><main>" + "\n".join(page.parts) + "</main></body></html>\n")


def write_report(path, text: str, force: bool = False) -> None:
    """Writes the page atomically; an existing file is replaced only with ``force``."""
    from .io import atomic_output

    path = os.fspath(path)
    if os.path.exists(path) and not force:
        raise ValueError(f"{path}: exists; choose another name or pass --force to replace it")
    with atomic_output(path) as f:
        f.write(text)
