"""Diagnosis on scenario families (studies/diagnosis_families.py): the held-out families next
to the tuning families (docs/families.md, docs/diagnose.md).

Each run draws one scenario of a family with one forced effect (every effect the family
schedules, the controls included), simulates it once, runs ``diagnose`` and, when there is a
process finding, ``update`` with the top one. Scoring per run, from the scenario's truth:

* top process finding right: its effect is the scheduled effect, on the changed channel (the
  changed input for an actuator nonlinearity, the changed output and the new column for an
  unmodelled input);
* false process finding: any process finding in a control run (no change, noise change, drift);
* update quality: the shown error's fall (``update``'s held-out one-step error) next to the
  true model error's fall: the step-response error of the changed channel against the
  scenario's true plant after the change, with the nominal model and with the updated one;
* the record's evidence for the true change (``true_evidence``): how far the scenario's true
  channel lowers the one-step error after the onset, so that a miss on a change the record
  barely shows is told apart from a miss of the method;
* every finding (process or not) with its confidence and whether it is right, for the
  reliability tables; an ``output_drift`` finding on an output the family gave a background
  step/ramp disturbance also counts as right (the drift is real, only not the scheduled effect),
  and so does, in a family with hand-written models, a linear channel finding from the first
  row whose update removes a quarter of its channel's error against the plant
  (``standing_error_named``: the model's own error, which a user needs to hear about too).
"""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from . import families as fam
from ._core import TransferFunction, actuator_positions
from .diagnose import PROCESS_EFFECTS, diagnose
from .diagnose.changes import apply_changes
from .diagnose.errors import one_step_errors
from .diagnose.pipeline import diagnosis_signals
from .diagnose.result import DISTURBANCE_EFFECTS, ModelChange
from .evaluate import nominal_model
from .parallel import run_tasks
from .scenario import parse_scenario
from .simulate import simulate
from .step_response import step_response_error
from .update import update

# Effects whose changed channel is linear, so a step response measures the model error.
LINEAR_EFFECTS = ("gain", "time_constant", "delay", "missing_coupling", "unmodeled_input")
CONFIDENCE_BINS = (0.0, 0.5, 0.9, 0.99, 1.0)
# A finding names a hand-written model's standing error when its update removes at least this
# share of its channel's step-response error against the plant (standing_error_named).
STANDING_ERROR_FALL = 0.25
# Evidence bins (chi-square units) for the accuracy-by-evidence table. Fixed a priori: below
# 10 no search over hundreds of candidate shapes and onsets can single out the truth; above 100
# the record shows the change plainly.
EVIDENCE_BINS = (0.0, 10.0, 30.0, 100.0, math.inf)
# A right top finding is also counted as *dated* when its onset lies within this of the
# scheduled change's (the tests' tolerance for onsets): the label alone is what the confidence is
# calibrated on, the date is what a user acts on (a valve named hours before it went bad).
DATED_WITHIN_S = 3600.0
EFFECT_ORDER = ("gain", "time_constant", "delay", "missing_coupling", "unmodeled_input",
                "input_nonlinearity") + fam.CONTROL_EFFECTS


def true_change(spec: dict, expect: dict) -> dict | None:
    """The scheduled change: {"output", "input" (an input or extra column, None for a noise
    change or drift), "channel" (true transfer function after the change, None if not linear),
    and for an actuator nonlinearity "actuator" (the engine's valve the plant switched to)}."""
    onset = expect.get("onset_s")
    if onset is None:
        return None
    sc = parse_scenario(spec)
    ts = spec["sample_time_s"]
    sample = int(round(onset / ts))
    names = {"process": sc.inputs, "extra_process": sc.extra_names}
    for ev, doc in zip(sc.events, sorted(spec["events"], key=lambda e: e["time_s"])):
        if ev.sample != sample or doc["type"] in ("setpoint", "mv_target"):
            continue
        kind = ev.kind.name
        output = sc.outputs[ev.output] if ev.output >= 0 else None
        if kind in names:
            return {"output": output, "input": names[kind][ev.input], "channel": ev.model}
        if kind == "actuator":
            return {"output": None, "input": sc.inputs[ev.input], "channel": None, "actuator": ev.actuator}
        if doc["type"] in ("noise", "sigma", "drift"):
            return {"output": output, "input": None, "channel": None}
    raise ValueError(f"{spec['name']}: no event at the onset {onset} s")


def finding_right(f: dict, effect: str, change: dict | None) -> bool:
    """Whether a finding names the scheduled effect where it happened."""
    if effect == "none" or change is None or f["effect"] != effect:
        return False
    if effect == "input_nonlinearity":
        return f.get("input") == change["input"]
    if effect in DISTURBANCE_EFFECTS:
        return f.get("output") == change["output"]
    return f.get("output") == change["output"] and f.get("input") == change["input"]


def _channel(model, output: str, column: str) -> TransferFunction | None:
    return model.process_dict().get(output, {}).get(column)


def drifting_outputs(spec: dict) -> set:
    """Outputs with a drift event (scheduled or a background step/ramp disturbance)."""
    return {ev["output"] for ev in spec["events"] if ev["type"] == "drift"}


def noise_changes(spec: dict) -> list[tuple[str, float]]:
    """(output, time) of every disturbance change of a draw (its noise_change control's, or the
    earlier one ``--earlier-noise-change`` adds)."""
    return [(ev["output"], float(ev["time_s"])) for ev in spec["events"] if ev["type"] in ("noise", "sigma")]


def names_a_noise_change(f, changes: list[tuple[str, float]], within_s: float = 3600.0) -> bool:
    """A noise_change finding on the output of one of ``changes``, dated within ``within_s`` of
    it: right whatever the run's effect (an earlier noise change is a real one; a process change
    hours later read as a noise change is not dated at it)."""
    return f.effect == "noise_change" and any(
        f.output == output and abs(f.onset_s - t) <= within_s for output, t in changes)


def standing_error_named(model, plant, f) -> bool:
    """For a model wrong from the start (a hand-written one): whether linear channel finding
    ``f`` names part of that error, i.e. its update lowers its channel's step-response error
    against the plant (``plant``, the model at the record's start) by at least
    STANDING_ERROR_FALL. A hand-written model is wrong in gain, time constant and dead time at
    once, so the label alone cannot be judged: what it is worth is how much of the error its
    fix removes."""
    truth = _channel(plant, f.output, f.input)
    if truth is None:
        return False
    before = step_response_error(_channel(model, f.output, f.input), truth)
    after = step_response_error(_channel(apply_changes(model, f.model_changes()), f.output, f.input), truth)
    return after <= (1.0 - STANDING_ERROR_FALL) * before


def _finding_record(f, effect: str, change: dict | None, drifting: set = frozenset(),
                    standing_named: bool = False, noises: list = ()) -> dict:
    d = f.to_dict()
    d["score"] = float(f.score)
    d["evidence_confidence"] = float(f.evidence_confidence)
    d["actuator_score"] = f.actuator_score
    d["calibrated"] = f.calibrated   # scored by its own calibration, not the family map
    d["process"] = f.effect in PROCESS_EFFECTS
    d["right"] = (finding_right(d, effect, change) or (f.effect == "output_drift" and f.output in drifting)
                  or names_a_noise_change(f, noises) or standing_named)
    return d


def run_diagnosis_seed(name: str, seed: int, effect: str, record_s: float | None = None,
                       channel_switch: str = "replay", earlier_noise_change: bool = False) -> dict:
    """One draw of family ``name`` with ``effect`` forced: diagnose, update with the top
    process finding, and score both against the truth."""
    family = fam.family(name)
    spec, expect = family.draw(seed, record_s, effect, channel_switch, earlier_noise_change)
    change = true_change(spec, expect)
    model = nominal_model(spec)
    t0 = time.perf_counter()
    data = simulate(spec)
    run = {"family": name, "split": family.split, "seed": int(seed), "effect": effect,
           "size": expect.get("size"), "samples": len(data), "sample_time_s": spec["sample_time_s"],
           "refused": None, "findings": [], "top_process": None, "top_right": False,
           "false_process": False, "update": None, "evidence": None, "onset_s": expect.get("onset_s")}
    try:
        diagnosis = diagnose(model, data)
    except ValueError as exc:  # diagnose refuses the data (too short): no finding, said plainly
        run["refused"] = str(exc)
        run["seconds"] = time.perf_counter() - t0
        return run
    start = diagnosis.start_s
    plant = nominal_model({**spec, "process": fam.plant_process(spec)})

    def standing_named(f) -> bool:   # a hand-written model's own error, named from the first row
        return (family.hand_written and f.effect in LINEAR_EFFECTS and f.onset_s <= start
                and standing_error_named(model, plant, f))

    run["findings"] = [_finding_record(f, effect, change, drifting_outputs(spec), standing_named(f), noise_changes(spec))
                       for f in diagnosis.findings]
    process = [f for f in diagnosis.findings if f.effect in PROCESS_EFFECTS]
    if family.hand_written:
        # The model is wrong from the start (as users' models are): what stands from the first
        # row is the model's own error, not the scheduled effect, and no false finding in a
        # control run; the top finding with an onset inside the record is judged.
        process = [f for f in process if f.onset_s > start]
    top = process[0] if process else None
    if top is not None:
        run["top_process"] = _finding_record(top, effect, change)
        run["top_right"] = run["top_process"]["right"]
    run["false_process"] = effect in fam.CONTROL_EFFECTS and top is not None
    if effect in LINEAR_EFFECTS:
        run["update"] = update_quality(model, data, top, change)
    if effect in LINEAR_EFFECTS or effect == "input_nonlinearity":
        # against the plant before the change (a hand-written model is not it)
        run["evidence"] = true_evidence(plant, data, change, expect["onset_s"])
    run["seconds"] = time.perf_counter() - t0
    return run


def true_evidence(model, data, change: dict, onset_s: float) -> float:
    """The record's evidence for the scheduled change: the drop of the output's squared one-step
    prediction error after the onset when the change is set to the truth (the channel, or the
    valve from the onset on), over the nominal error's variance before the onset (a
    likelihood-ratio statistic with the true change's structure, size and onset known; the
    disturbance model is diagnose's, the file's or the estimated one). A change that a record
    shows by less than a few units of it cannot be named by any search, whatever its size in
    the plant."""
    return change_evidence(diagnosis_signals(model, data).sig, change, onset_s)


def change_evidence(sig, change: dict, onset_s: float) -> float:
    """``true_evidence`` on deviation signals ``sig``, whose noise models whiten the error. An
    actuator nonlinearity's is summed over the outputs its input drives."""
    onset = sig.seconds_to_index(onset_s)

    def drop(i, after):
        before = one_step_errors(sig, i, [])
        return float(np.nansum(before[onset:] ** 2 - after[onset:] ** 2) / np.nanvar(before[:onset]))

    if change.get("actuator") is not None:
        j = sig.inputs.index(change["input"])
        level = sig.operating_point[change["input"]]
        op = sig.u[onset:, j] + level
        u = sig.u.copy()   # the valve from the onset on, starting at rest where the input stood
        u[onset:, j] = np.asarray(actuator_positions(op, change["actuator"], float(op[0]))) - level
        valved = dataclasses.replace(sig, u=u)
        driven = [i for i in range(len(sig.outputs)) if sig.rows[i][j] is not None]
        return sum(drop(i, one_step_errors(valved, i, [])) for i in driven)
    i = sig.outputs.index(change["output"])
    truth = ModelChange(output=change["output"], input=change["input"], channel=change["channel"],
                        new_input=change["input"] not in sig.inputs)
    return drop(i, one_step_errors(sig, i, [truth]))


def update_quality(model, data, top, change: dict) -> dict:
    """Shown error and true step-response error of the changed channel, before and after
    applying the top process finding (no finding: nothing applied, nothing falls)."""
    truth = change["channel"]
    before = step_response_error(_channel(model, change["output"], change["input"]), truth)
    if top is None:
        return {"true_before": before, "true_after": before, "shown_before": None, "shown_after": None,
                "process_before": None, "process_after": None}
    up = update(model, data, top.id)
    after = step_response_error(_channel(up.model, change["output"], change["input"]), truth)
    shown = next((e for e in up.errors if e.output == top.output), up.errors[0])
    return {"true_before": before, "true_after": after,
            "shown_before": shown.error_before, "shown_after": shown.error_after,
            "process_before": shown.process_error_before, "process_after": shown.process_error_after}


def run_study(names=None, seeds=range(4), record_s=None, scheduler=None, workers=None,
              progress: bool = True, channel_switch: str = "replay", earlier_noise_change: bool = False) -> dict:
    """Every (family, effect, seed) run in parallel (``parallel.run_tasks``)."""
    names = [f.name for f in fam.FAMILIES] if names is None else list(names)
    tasks = [(n, s, e, record_s, channel_switch, earlier_noise_change)
             for n in names for e in fam.family(n).effects for s in seeds]
    started = time.perf_counter()
    runs, where = run_tasks(run_diagnosis_seed, tasks, scheduler, workers, progress, unit="runs")
    runs.sort(key=lambda r: (names.index(r["family"]), r["effect"], r["seed"]))
    return {"runs": runs, "seeds": list(seeds), "where": where, "wall_seconds": time.perf_counter() - started,
            "channel_switch": channel_switch, "earlier_noise_change": earlier_noise_change}


# ---- tables --------------------------------------------------------------------------------

def _frac(k: int, n: int) -> str:
    return f"{k}/{n} ({100.0 * k / n:.0f}%)" if n else "-"


def _median(xs) -> str:
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    return f"{np.median(xs):+.0f}%" if xs else "-"


def dated(run: dict) -> bool:
    """Whether a run's top process finding is right and dated within DATED_WITHIN_S of the
    scheduled change (False for a run recorded without the change's onset)."""
    return bool(run["top_right"]) and run.get("onset_s") is not None and \
        abs(run["top_process"]["onset_s"] - run["onset_s"]) <= DATED_WITHIN_S


def accuracy_rows(runs: list) -> list:
    """Per split and effect: right top process finding (change runs) or runs with a false
    process finding (controls), of the right ones those dated within DATED_WITHIN_S, and runs
    diagnose refused."""
    rows = []
    for split in (fam.TUNING, fam.HELD_OUT):
        for effect in [e for e in EFFECT_ORDER if any(r["effect"] == e for r in runs)]:
            rs = [r for r in runs if r["split"] == split and r["effect"] == effect]
            if not rs:
                continue
            control = effect in fam.CONTROL_EFFECTS
            k = sum(r["false_process"] if control else r["top_right"] for r in rs)
            named = {}
            for r in rs:
                if control and r["false_process"] or not control and not r["top_right"]:
                    label = r["top_process"]["effect"] if r["top_process"] else "no process finding"
                    named[label] = named.get(label, 0) + 1
            rows.append({"split": split, "effect": effect, "control": control, "k": k, "n": len(rs),
                         "dated": None if control else sum(dated(r) for r in rs),
                         "refused": sum(r["refused"] is not None for r in rs), "misses": named})
    return rows


def family_rows(runs: list, high: float = 0.9) -> list:
    """Per family, in the runs' order: right top process findings over the change runs, control
    runs with a false process finding, and findings at >= ``high`` right."""
    rows: dict = {}
    for r in runs:
        row = rows.setdefault(r["family"], {"split": r["split"], "family": r["family"], "right": 0, "changes": 0,
                                            "false": 0, "controls": 0, "right_high": 0, "n_high": 0})
        if r["effect"] in fam.CONTROL_EFFECTS:
            row["false"] += r["false_process"]
            row["controls"] += 1
        else:
            row["right"] += r["top_right"]
            row["changes"] += 1
        high_findings = [f for f in r["findings"] if f["confidence"] >= high]
        row["n_high"] += len(high_findings)
        row["right_high"] += sum(f["right"] for f in high_findings)
    return list(rows.values())


def evidence_rows(runs: list, effects=LINEAR_EFFECTS) -> list:
    """Per split and evidence bin (``true_evidence``), over the change runs of ``effects``:
    right top process finding, and runs without any process finding."""
    rows = []
    for split in (fam.TUNING, fam.HELD_OUT):
        rs = [r for r in runs if r["split"] == split and r["effect"] in effects and r.get("evidence") is not None]
        for lo, hi in zip(EVIDENCE_BINS[:-1], EVIDENCE_BINS[1:]):
            # a negative evidence (the truth predicts worse than the model: noise) is no evidence
            inside = [r for r in rs if lo <= max(r["evidence"], 0.0) < hi]
            if inside:
                rows.append({"split": split, "bin": f"[{lo:g}, {hi:g})", "n": len(inside),
                             "right": sum(r["top_right"] for r in inside),
                             "none": sum(r["top_process"] is None for r in inside)})
    return rows


def update_rows(runs: list) -> list:
    """Per split and effect: over the runs with a process finding, the median fall of the shown
    errors (one-step, process part) and of the true error; over all runs, the share of runs
    whose true step-response error at least halved, and the share where the shown error fell
    while the true one rose."""
    rows = []
    for split in (fam.TUNING, fam.HELD_OUT):
        for effect in LINEAR_EFFECTS:
            us = [r["update"] for r in runs if r["split"] == split and r["effect"] == effect and r["update"]]
            if not us:
                continue
            shown = [100 * (u["shown_after"] / u["shown_before"] - 1) for u in us if u["shown_before"]]
            process = [100 * (u["process_after"] / u["process_before"] - 1) for u in us if u["process_before"]]
            true = [100 * (u["true_after"] / u["true_before"] - 1) for u in us if u["shown_before"]]
            halved = sum(u["true_after"] <= 0.5 * u["true_before"] for u in us)
            misleading = sum(u["shown_before"] is not None and u["shown_after"] < u["shown_before"]
                             and u["true_after"] > u["true_before"] for u in us)
            rows.append({"split": split, "effect": effect, "n": len(us), "updated": len(true), "shown": _median(shown),
                         "process": _median(process),
                         "true": _median(true), "halved": halved, "misleading": misleading})
    return rows


def reliability_rows(runs: list, key: str = "confidence") -> list:
    """Findings binned by their reported confidence (``key``): count and fraction right."""
    rows = []
    for split in sorted({r["split"] for r in runs}, key=(fam.TUNING, fam.HELD_OUT).index):
        fs = [f for r in runs if r["split"] == split for f in r["findings"]
              if f.get(key) is not None and math.isfinite(f[key])]
        for lo, hi in zip(CONFIDENCE_BINS[:-1], CONFIDENCE_BINS[1:]):
            inside = [f for f in fs if lo <= f[key] < hi or (hi == 1.0 and f[key] == 1.0)]
            rows.append({"split": split, "bin": f"[{lo:g}, {hi:g}{']' if hi == 1.0 else ')'}",
                         "n": len(inside), "right": sum(f["right"] for f in inside)})
    return rows


def onset_set_rows(runs: list) -> list:
    """Per split and effect, over the right top findings that carry an onset set (a channel
    change: onset_earliest_s .. onset_latest_s): how many, how many hold the change's onset, and
    the sets' median width in hours."""
    rows = []
    for split in (fam.TUNING, fam.HELD_OUT):
        for effect in EFFECT_ORDER:
            rs = [r for r in runs if r["split"] == split and r["effect"] == effect and r["top_right"]
                  and r.get("onset_s") is not None and "onset_earliest_s" in r["top_process"]]
            if rs:
                sets = [(r["top_process"]["onset_earliest_s"], r["top_process"]["onset_latest_s"], r["onset_s"])
                        for r in rs]
                rows.append({"split": split, "effect": effect, "n": len(rs),
                             "held": sum(a <= t <= b for a, b, t in sets),
                             "width_h": float(np.median([(b - a) / 3600.0 for a, b, _ in sets]))})
    return rows


def reliability_by_effect(runs: list, high: float = 0.9) -> list:
    """Per split and reported effect: findings and how many right, all and at >= ``high``."""
    rows = []
    for split in sorted({r["split"] for r in runs}, key=(fam.TUNING, fam.HELD_OUT).index):
        fs = [f for r in runs if r["split"] == split for f in r["findings"]]
        for effect in [e for e in EFFECT_ORDER if any(f["effect"] == e for f in fs)]:
            mine = [f for f in fs if f["effect"] == effect]
            top = [f for f in mine if f["confidence"] >= high]
            rows.append({"split": split, "effect": effect, "n": len(mine), "right": sum(f["right"] for f in mine),
                         "n_high": len(top), "right_high": sum(f["right"] for f in top)})
    return rows


def _table(title: str, columns: list[str], cells: list[list]) -> list[str]:
    """A titled Markdown table, preceded by a blank line."""
    return (["", title, "", "| " + " | ".join(columns) + " |", "|" + " --- |" * len(columns)]
            + ["| " + " | ".join(str(c) for c in row) + " |" for row in cells])


def _evidence_table(title: str, rows: list) -> list[str]:
    return _table(title, ["split", "evidence", "runs", "right", "no process finding"],
                  [[r["split"], r["bin"], r["n"], _frac(r["right"], r["n"]), _frac(r["none"], r["n"])] for r in rows])


def format_tables(study: dict) -> str:
    runs = study["runs"]
    accuracy = []
    for r in accuracy_rows(runs):
        label = f"control: {r['effect']}" if r["control"] else r["effect"]
        misses = ", ".join(f"{k} {v}" for k, v in sorted(r["misses"].items())) or "-"
        accuracy.append([r["split"], label, _frac(r["k"], r["n"]),
                         "-" if r["control"] else _frac(r["dated"], r["n"]), r["refused"], misses])
    for split in sorted({r["split"] for r in runs}, key=(fam.TUNING, fam.HELD_OUT).index):
        change = [r for r in runs if r["split"] == split and r["effect"] not in fam.CONTROL_EFFECTS]
        control = [r for r in runs if r["split"] == split and r["effect"] in fam.CONTROL_EFFECTS]
        accuracy.append([split, "all changes / all controls",
                         f"{_frac(sum(r['top_right'] for r in change), len(change))}"
                         f" / {_frac(sum(r['false_process'] for r in control), len(control))}",
                         _frac(sum(dated(r) for r in change), len(change)), "", ""])
    out = _table("Top process finding (change runs: right / runs, and right with its onset within "
                 f"{DATED_WITHIN_S / 3600:g} h of the change's; controls: runs with a false process finding)",
                 ["split", "effect", "right or false", "right and dated", "diagnose refused",
                  "what misses and false findings named"],
                 accuracy)[1:]   # the first table opens the text
    out += _evidence_table("Linear changes by the record's evidence for them (the one-step likelihood-ratio gain "
                           "of the true change after its onset, chi-square units)", evidence_rows(runs))
    out += _evidence_table("Actuator nonlinearities by the record's evidence for them (the same statistic with "
                           "the true valve from the onset, summed over the outputs its input drives)",
                           evidence_rows(runs, ("input_nonlinearity",)))
    out += _table("Update with the top process finding (over the runs with one: median change of the shown "
                  "held-out errors, one-step and process part, and of the true step-response error of the changed "
                  "channel; 'true error halved' over all runs, a run without a process finding counts as not halved)",
                  ["split", "effect", "runs", "updated", "one-step error", "process part", "true error",
                   "true error halved", "one-step fell, true rose"],
                  [[r["split"], r["effect"], r["n"], r["updated"], r["shown"], r["process"], r["true"],
                    _frac(r["halved"], r["n"]), r["misleading"]] for r in update_rows(runs)])
    out += _table("Confidence reliability (every finding, binned by its reported confidence: the calibrated "
                  "probability, and the chi-square CDF of its held-out gain)",
                  ["split", "confidence", "findings (calibrated)", "right", "findings (chi-square)", "right"],
                  [[r["split"], r["bin"], r["n"], _frac(r["right"], r["n"]), c["n"], _frac(c["right"], c["n"])]
                   for r, c in zip(reliability_rows(runs), reliability_rows(runs, "evidence_confidence"))])
    out += _table("Reliability per reported effect (calibrated confidence)",
                  ["split", "finding", "findings", "right", "at >= 0.9", "right at >= 0.9"],
                  [[r["split"], r["effect"], r["n"], _frac(r["right"], r["n"]), r["n_high"],
                    _frac(r["right_high"], r["n_high"])] for r in reliability_by_effect(runs)])
    out += _table("Onset sets (right top findings of a channel change: the onsets the data cannot tell from the "
                  "reported one, diagnose's onset_earliest_s .. onset_latest_s; does the set hold the change's onset)",
                  ["split", "effect", "findings with a set", "set holds the onset", "median width (h)"],
                  [[r["split"], r["effect"], r["n"], _frac(r["held"], r["n"]), f"{r['width_h']:.2f}"]
                   for r in onset_set_rows(runs)])
    out += _table("Per family (top process finding right / change runs; control runs with a false process finding; "
                  "findings at >= 0.9 right)", ["split", "family", "right", "controls false", "right at >= 0.9"],
                  [[r["split"], r["family"], _frac(r["right"], r["changes"]), _frac(r["false"], r["controls"]),
                    _frac(r["right_high"], r["n_high"])] for r in family_rows(runs)])
    out.append(f"\n{len(runs)} runs, seeds {study['seeds'][0]}-{study['seeds'][-1]}, "
               f"{study['wall_seconds']:.0f} s wall on {study['where']}{fam.variant_note(study)}")
    return "\n".join(out)
