"""Monte Carlo evaluation of the detector against baselines (``mpmpp evaluate``).

Each seed is one closed-loop simulation of the scenario (``mpmpp.simulate``); on it the
detector and the baselines (``mpmpp.baselines``) run on the same windows. Per channel:

* MPM detection rate: share of runs with an MPM alarm starting at or after the channel's
  process change (changed channels only);
* false MPM alarm rate: share of runs with an MPM alarm starting before the channel's change,
  including during a noise change, or at any time on a channel that never changed;
* detection delay: first alarm start at or after the change minus the change time
  (median and 90th percentile over the detected runs).
The same for noise-change alarms per output. The baselines raise per-output alarms (they
cannot localise a channel); each counts as an MPM alarm on every channel of that output.

Seeds run in parallel: all local cores by default (processes), or on a Dask cluster
(``scheduler=ADDRESS`` or a ``dask.distributed.Client``); a run's result does not depend on
where it ran.
"""
from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass

import numpy as np

from . import scenarios
from . import _core
from ._core import DetectorConfig, Model
from .parallel import run_tasks
from .simulate import simulate
from .baselines import BASELINES, baseline_alarms, baseline_indices
from .detect import _arrays, channel_label, detect, make_config

__all__ = ["run_seed", "evaluate", "summarise", "format_table", "load_scenario"]


def load_scenario(spec):
    """'paper-siso' | 'paper-mimo' | a scenario JSON file path | a scenario dict -> scenario dict."""
    if isinstance(spec, dict):
        return spec
    if spec in ("paper-siso", "paper_siso"):
        return scenarios.paper_siso()
    if spec in ("paper-mimo", "paper_mimo"):
        return scenarios.paper_mimo()
    path = os.fspath(spec)
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as exc:
        raise ValueError(f"{path}: cannot read the scenario ({exc.strerror})") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc})") from None


_MODEL_KEYS = ("name", "sample_time_s", "inputs", "outputs", "process", "noise")


def nominal_model(scenario: dict):
    """The model the scenario's controller uses (the model-file part of the scenario)."""
    doc = {k: scenario[k] for k in _MODEL_KEYS if k in scenario}
    # Scenario documents may write noise models with "delay": 0, which model files do not take.
    doc["noise"] = {o: {k: v for k, v in h.items() if not (k == "delay" and v == 0)}
                    for o, h in doc.get("noise", {}).items()}
    return Model.from_json(json.dumps(doc), "scenario")


# Scenario event types that change a process channel's truth / an output's noise model.
_PROCESS_EVENTS = ("process", "gain", "time_constant", "delay")


def truth_onsets(scenario: dict, config: DetectorConfig | None = None) -> dict:
    """First change time (s) per monitored channel, None if it never changes:
    {"process": {(output, input): t}, "noise": {output: t}} over the process channels ``config``
    monitors (the model's, and with its absent channels those the model lacks: a coupling that
    appears there changes its channel), by default the model's."""
    model = nominal_model(scenario)
    pairs = model.channels() if config is None else [
        (model.outputs[i], model.inputs[j]) for kind, i, j in _core.WindowFeatures(model, config).channels
        if kind == "process"]
    process = {(o, i): None for o, i in pairs}
    noise = {o: None for o in model.outputs}
    for ev in scenario.get("events", []):
        t = float(ev["time_s"])
        if ev["type"] in _PROCESS_EVENTS and (ev["output"], ev["input"]) in process:
            key = (ev["output"], ev["input"])
            process[key] = t if process[key] is None else min(process[key], t)
        elif ev["type"] == "noise":
            noise[ev["output"]] = t if noise[ev["output"]] is None else min(noise[ev["output"]], t)
    return {"process": process, "noise": noise}


def _label(key) -> str:
    """The channel label of a truth key: (output, input) for a process channel, output for noise."""
    if isinstance(key, tuple):
        return channel_label({"kind": "process", "output": key[0], "input": key[1]})
    return channel_label({"kind": "noise", "output": key})


def run_seed(spec, seed: int, config_json: str | None = None) -> dict:
    """One Monte Carlo run: simulate, detect, baselines. Returns plain data (picklable)."""
    t_start = time.perf_counter()
    scenario = load_scenario(spec)
    model = nominal_model(scenario)
    config = make_config(json.loads(config_json) if config_json else None, model)
    data = simulate(scenario, seed=int(seed))
    t_sim = time.perf_counter()
    result = detect(model, data, config.train_duration_s, config)
    t_det = time.perf_counter()
    time_s, u, y = _arrays(model, data)
    w = result.windows
    indices = baseline_indices(model, time_s, u, y, w["first"].to_numpy(), config.window_samples(model.sample_time_s),
                               w["training"].to_numpy())
    base = baseline_alarms(indices, w["end_s"].to_numpy(), config.inspection_windows(), config.alarm_count())
    t0 = float(time_s[0])
    return {
        "seed": int(seed),
        "channels": [channel_label(c) for c in result.channels],
        "alarms": {channel_label(c): [s - t0 for s in result.alarm_starts(k)] for k, c in enumerate(result.channels)},
        "baselines": {name: {model.outputs[i]: [s - t0 for s in starts] for i, starts in per_out.items()}
                      for name, per_out in base.items()},
        "skipped_windows": int(w["skipped"].sum()),
        "seconds": {"simulate": t_sim - t_start, "detect": t_det - t_sim,
                    "total": time.perf_counter() - t_start},
    }


def evaluate(spec, seeds, config=None, scheduler=None, workers=None, progress: bool = True) -> dict:
    """Runs every seed (a count N means seeds 0..N-1) and summarises (see ``summarise``).

    scheduler: None (local processes, ``workers`` of them, default all cores), a Dask scheduler
    address, or a ``dask.distributed.Client``."""
    seeds = list(range(seeds)) if isinstance(seeds, int) else [int(s) for s in seeds]
    if not seeds:
        raise ValueError("seeds: need at least one seed")
    scenario = load_scenario(spec)
    cfg = make_config(config, nominal_model(scenario))
    config_json = cfg.to_json()
    started = time.perf_counter()
    # The scenario travels as a plain dict: picklable to any worker.
    runs, where = run_tasks(run_seed, [(scenario, s, config_json) for s in seeds], scheduler, workers,
                            progress, unit="runs")
    wall = time.perf_counter() - started
    runs.sort(key=lambda r: r["seed"])
    summary = summarise(runs, truth_onsets(scenario, cfg), nominal_model(scenario))
    summary.update({"scenario": spec if isinstance(spec, str) else scenario.get("name", "scenario"),
                    "seeds": len(seeds), "seed_range": [min(seeds), max(seeds)], "wall_seconds": wall, "where": where,
                    "cpu_seconds": float(sum(r["seconds"]["total"] for r in runs)),
                    "config": json.loads(config_json)})
    return summary


@dataclass
class _Rates:
    detected: int = 0
    false: int = 0
    delays: list = None


def _score(starts, onset, rates: _Rates):
    """Counts one run's alarm starts against the change time (None: never changed)."""
    starts = sorted(starts)
    if onset is None:
        rates.false += bool(starts)
        return
    if any(s < onset for s in starts):
        rates.false += 1
    after = [s for s in starts if s >= onset]
    if after:
        rates.detected += 1
        rates.delays.append(after[0] - onset)


def _row(name, kind, onset, rates: _Rates, n: int, method: str) -> dict:
    d = np.asarray(rates.delays, dtype=float)
    return {"method": method, "channel": name, "kind": kind,
            "changed_at_s": onset,
            "detection_rate": None if onset is None else rates.detected / n,
            "false_alarm_rate": rates.false / n,
            "delay_median_s": float(np.median(d)) if d.size else None,
            "delay_p90_s": float(np.percentile(d, 90)) if d.size else None}


def summarise(runs: list, onsets: dict, model) -> dict:
    """Rates per channel for the detector and the baselines.

    onsets: {"process": {(output, input): seconds or None}, "noise": {output: seconds or None}}.
    """
    n = len(runs)
    rows = []
    any_false_mpm = 0
    any_false_noise = 0
    for kind in ("process", "noise"):
        for key, onset in onsets[kind].items():
            label = _label(key)
            rates = _Rates(delays=[])
            for r in runs:
                _score(r["alarms"].get(label, []), onset, rates)
            rows.append(_row(label, "MPM" if kind == "process" else "noise", onset, rates, n, "svm"))
    for r in runs:
        any_false_mpm += any(any(s < (onsets["process"][k] if onsets["process"][k] is not None else np.inf)
                                 for s in r["alarms"].get(_label(k), []))
                             for k in onsets["process"])
        any_false_noise += any(any(s < (onsets["noise"][k] if onsets["noise"][k] is not None else np.inf)
                                   for s in r["alarms"].get(_label(k), []))
                               for k in onsets["noise"])
    baseline_confusion = {}
    noise_onsets = [t for t in onsets["noise"].values() if t is not None]
    for name in BASELINES:
        false_any = 0
        for key, onset in onsets["process"].items():
            rates = _Rates(delays=[])
            for r in runs:
                _score(r["baselines"][name].get(key[0], []), onset, rates)
            rows.append(_row(_label(key), "MPM", onset, rates, n, name))
        # Confusion: an alarm on an output whose noise changed, after that change and before
        # any process change of that output.
        confused = 0
        for r in runs:
            hit = False
            for out, t_noise in onsets["noise"].items():
                if t_noise is None:
                    continue
                t_proc = min([t for (o, _), t in onsets["process"].items() if o == out and t is not None],
                             default=np.inf)
                hit |= any(t_noise <= s < t_proc for s in r["baselines"][name].get(out, []))
            confused += hit
            false_any += any(any(s < (t if t is not None else np.inf) for s in r["baselines"][name].get(o, []))
                             for (o, _), t in onsets["process"].items())
        baseline_confusion[name] = {"noise_change_alarm_rate": confused / n if noise_onsets else None,
                                    "any_false_mpm_rate": false_any / n}
    # The detector's own confusion: an MPM alarm between a noise change and the process change.
    confused = 0
    for r in runs:
        hit = False
        for t_noise in onsets["noise"].values():
            if t_noise is None:
                continue
            for (o, i), t in onsets["process"].items():
                t_proc = t if t is not None else np.inf
                hit |= any(t_noise <= s < t_proc for s in r["alarms"].get(_label((o, i)), []))
        confused += hit
    seconds = np.array([r["seconds"]["total"] for r in runs])
    return {"rows": rows,
            "svm": {"any_false_mpm_rate": any_false_mpm / n, "any_false_noise_rate": any_false_noise / n,
                    "noise_change_alarm_rate": confused / n if noise_onsets else None},
            "baselines": baseline_confusion,
            "run_seconds_median": float(np.median(seconds)),
            "skipped_windows": int(sum(r["skipped_windows"] for r in runs))}


def _fmt_h(s):
    return "-" if s is None else f"{s / 3600:.2f}"


def _fmt_rate(x):
    return "-" if x is None else f"{100 * x:.0f}%"


def format_table(summary: dict) -> str:
    """Markdown table of the summary (also the human output of ``mpmpp evaluate``)."""
    lo, hi = summary.get("seed_range", [0, summary["seeds"] - 1])
    lines = [f"{summary['scenario']}: {summary['seeds']} seeds ({lo}-{hi}), {summary['wall_seconds']:.0f} s wall on "
             f"{summary['where']} ({summary['cpu_seconds']:.0f} s of runs)", "",
             "| method | channel | alarm | changed at (h) | detected | false alarm | delay median (h) | delay p90 (h) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in summary["rows"]:
        lines.append(f"| {r['method']} | {r['channel']} | {r['kind']} | {_fmt_h(r['changed_at_s'])} | "
                     f"{_fmt_rate(r['detection_rate'])} | {_fmt_rate(r['false_alarm_rate'])} | "
                     f"{_fmt_h(r['delay_median_s'])} | {_fmt_h(r['delay_p90_s'])} |")
    s = summary["svm"]
    lines += ["", f"svm: runs with any false MPM alarm {_fmt_rate(s['any_false_mpm_rate'])}, any false noise "
                  f"alarm {_fmt_rate(s['any_false_noise_rate'])}, MPM alarm during the noise change "
                  f"{_fmt_rate(s['noise_change_alarm_rate'])}"]
    for name, b in summary["baselines"].items():
        lines.append(f"{name}: runs with any false MPM alarm {_fmt_rate(b['any_false_mpm_rate'])}, alarm during "
                     f"the noise change (confuses it with MPM) {_fmt_rate(b['noise_change_alarm_rate'])}")
    return "\n".join(lines)
