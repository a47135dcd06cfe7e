"""Detection on scenario families (``mpmpp evaluate --families``, studies/detection_families.py).

Each run draws one scenario of a family (``mpmpp.families``) from its seed, simulates it once
and runs ``detect`` with every preset of the run's size on the same data (``siso`` and
``paper_siso`` for one output, ``mimo`` and ``paper_mimo`` otherwise). Scoring per run and
preset, from the family's expectation:

* false MPM alarm: an MPM alarm starting before the change; in a control run (no change, a
  noise change, a drift) any MPM alarm at all;
* false noise alarm: a noise alarm starting before the change (any, in a no-change run): the
  disturbance had not changed then;
* detected (change runs): an MPM alarm on one of the expected channels starting at or after
  the change (for an unmodelled measured input also a noise alarm on its output);
* delay: the first such alarm start minus the change time;
* mislocated: an MPM alarm at or after the change only on channels outside the expected ones;
* read as a noise change: not detected, but a noise alarm on a changed output at or after the
  change (the process change was seen and put down to the disturbance);
* refused: detect raised an error on the data (counted as no alarm: not detected, no false alarm).

Per linear change run, the record's evidence for the change (``evidence``): the one-step
likelihood-ratio statistic of the true change after its onset (diagnosis_study.change_evidence),
whitened with the scenario's *true* disturbance model, so it measures what the data hold with
the disturbance known, independently of any detector. Detection by evidence bin separates the
changes no detector could see from those the presets miss.
"""
from __future__ import annotations

import math
import time

import numpy as np

from . import families as fam
from .detect import channel_label, detect, make_config
from .diagnosis_study import EVIDENCE_BINS, LINEAR_EFFECTS, change_evidence, finding_right, true_change
from .evaluate import nominal_model
from .noise_alarm_check import check_noise_alarms
from .parallel import run_tasks
from .signals import extract
from .simulate import simulate

# The diagnosis study's bins with [100, inf) split at 1000: a detector's misses above 1000 are
# changes the record shows plainly (a missed gain change of evidence 65,000 on seeds 40-59).
DETECTION_EVIDENCE_BINS = EVIDENCE_BINS[:-1] + (1000.0, math.inf)


def presets_for(size: int) -> tuple:
    """The recommended and the paper's preset for a plant of `size` outputs."""
    return ("siso", "paper_siso") if size == 1 else ("mimo", "paper_mimo")


def is_paper(preset: str) -> bool:
    """A label of one of the paper's presets (every other label is scored as recommended)."""
    return preset.startswith("paper_")


def score(alarms: dict, expect: dict) -> dict:
    """One run's alarm starts ({label: [seconds from the start]}) against its expectation."""
    onset = expect["onset_s"]
    mpm = {k: v for k, v in alarms.items() if k.startswith("G[")}
    control = expect["kind"] == "none"
    before = math.inf if control or onset is None else onset
    false_mpm = any(s < before for v in mpm.values() for s in v)
    quiet_until = math.inf if expect.get("effect") == "none" or onset is None else onset
    false_noise = any(s < quiet_until for k, v in alarms.items() if k.startswith("H[") for s in v)
    out = {"false_mpm": bool(false_mpm), "false_noise": bool(false_noise), "detected": None, "delay_s": None,
           "mislocated": None, "read_as_noise": None}
    if control:
        return out
    hits = [channel_label({"kind": "process", "output": o, "input": i})
            for o, i in expect["channels"] + ([expect["absent_channel"]] if "absent_channel" in expect else [])]
    if expect["kind"] == "any":
        hits.append(channel_label({"kind": "noise", "output": expect["output"]}))
    after = [s for k in hits for s in alarms.get(k, []) if s >= onset]
    out["detected"] = bool(after)
    out["delay_s"] = min(after) - onset if after else None
    elsewhere = any(s >= onset for k, v in mpm.items() if k not in hits for s in v)
    out["mislocated"] = bool(elsewhere and not after)
    noise = [channel_label({"kind": "noise", "output": o}) for o in dict.fromkeys(o for o, _ in expect["channels"])]
    out["read_as_noise"] = not after and any(s >= onset for k in noise for s in alarms.get(k, []))
    return out


def score_checks(checks: list, expect: dict, change: dict | None) -> dict:
    """The noise-alarm checks of one run (noise_alarm_check.py): how many, whether one names the
    scheduled ``change`` (diagnosis_study.true_change, finding_right), whether one names a process
    change in a control run (no change, a noise change, a drift: the process did not change)."""
    control = expect["kind"] == "none"
    found = [c.finding for c in checks if c.finding is not None]
    return {"checks": len(checks),
            "check_named": not control and change is not None
            and any(finding_right(f, expect["effect"], change) for f in found),
            "check_false": control and bool(found)}


def evidence(spec: dict, expect: dict, data, change: dict | None) -> float | None:
    """The record's evidence for a linear ``change`` (module docstring; diagnosis_study.true_change),
    None for other effects."""
    if expect.get("effect") not in LINEAR_EFFECTS:
        return None
    # The plant before the change (a hand-written model file is not it): the evidence is the
    # change's alone.
    truth = nominal_model({**spec, "process": fam.plant_process(spec), "noise": spec["truth"]["noise"]})
    return change_evidence(extract(truth, data), change, expect["onset_s"])


def run_family_seed(name: str, seed: int, record_s: float | None = None, configs: dict | None = None,
                    effect: str | None = None, channel_switch: str = "replay",
                    earlier_noise_change: bool = False) -> dict:
    """Simulate one draw of family `name` and score every preset of its size on it, or every
    detector config of `configs` ({label: preset name, config dict or file}). effect forces
    one of the family's effects; channel_switch and earlier_noise_change are Family.draw's."""
    family = fam.family(name)
    spec, expect = family.draw(seed, record_s, effect, channel_switch, earlier_noise_change)
    model = nominal_model(spec)
    t0 = time.perf_counter()
    data = simulate(spec)
    change = true_change(spec, expect)
    result = {"family": name, "split": family.split, "seed": int(seed), "expect": expect,
              "samples": len(data), "sample_time_s": spec["sample_time_s"], "presets": {},
              "evidence": evidence(spec, expect, data, change), "seconds": {"simulate": time.perf_counter() - t0}}
    configs = configs or {p: p for p in presets_for(family.size)}
    for preset, given in configs.items():
        make_config(given, model)  # a bad config is an error here, not a refusal of every run
        t1 = time.perf_counter()
        try:  # trained for the config's training duration, resolved at the family's sample time
            det = detect(model, data, config=given)
        except ValueError as exc:  # the detector refuses the data (e.g. no usable training window)
            result["presets"][preset] = {**score({}, expect), "refused": str(exc), "alarms": {}}
            continue
        alarms = {channel_label(c): [float(s) - float(data["time"].iloc[0]) for s in det.alarm_starts(k)]
                  for k, c in enumerate(det.channels)}
        result["presets"][preset] = {**score(alarms, expect), "refused": None, "alarms": alarms}
        if not is_paper(preset):  # the paper's presets raise noise alarms in most runs
            result["presets"][preset].update(score_checks(check_noise_alarms(model, data, det), expect, change))
        result["seconds"][preset] = time.perf_counter() - t1
    return result


def run_study(names=None, seeds=range(4), record_s=None, scheduler=None, workers=None,
              progress: bool = True, configs: dict | None = None, channel_switch: str = "replay",
              earlier_noise_change: bool = False) -> dict:
    """Every (family, seed) run in parallel (``parallel.run_tasks``); rows per family and
    preset (or per label of `configs`, see run_family_seed)."""
    names = [f.name for f in fam.FAMILIES] if names is None else list(names)
    for n in names:
        fam.family(n)  # unknown names fail before any work starts
    seeds = list(seeds)
    started = time.perf_counter()
    runs, where = run_tasks(run_family_seed, [(n, s, record_s, configs, None, channel_switch, earlier_noise_change)
                                              for n in names for s in seeds],
                            scheduler, workers, progress, unit="runs")
    runs.sort(key=lambda r: (names.index(r["family"]), r["seed"]))
    return {"rows": summarise(runs, names, configs), "runs": runs, "seeds": seeds, "where": where,
            "wall_seconds": time.perf_counter() - started, "channel_switch": channel_switch,
            "earlier_noise_change": earlier_noise_change}


def summarise(runs: list, names: list, configs: dict | None = None) -> list:
    rows = []
    for name in names:
        f = fam.family(name)
        mine = [r for r in runs if r["family"] == name]
        for preset in configs or presets_for(f.size):
            scored = [r["presets"][preset] for r in mine]
            changes = [s for s in scored if s["detected"] is not None]
            delays = np.array([s["delay_s"] for s in changes if s["delay_s"] is not None], float)
            rows.append({"family": name, "split": f.split, "preset": preset, "runs": len(scored),
                         "changes": len(changes), "detected": sum(s["detected"] for s in changes),
                         "false_mpm": sum(s["false_mpm"] for s in scored),
                         "false_noise": sum(s["false_noise"] for s in scored),
                         "mislocated": sum(s["mislocated"] for s in changes),
                         "refused": sum(s["refused"] is not None for s in scored),
                         "delay_median_s": float(np.median(delays)) if delays.size else None,
                         "delay_p90_s": float(np.percentile(delays, 90)) if delays.size else None})
    return rows


def by_effect(runs: list) -> list:
    """Runs pooled per split, preset kind (recommended: siso/mimo; paper: paper_*) and effect
    (actuator nonlinearities by kind): detected and false-MPM-alarm counts."""
    cells = {}
    for r in runs:
        e = r["expect"]
        effect = e["effect"] + (f":{e['nonlinearity']}" if "nonlinearity" in e else "")
        for preset, v in r["presets"].items():
            kind = "paper" if is_paper(preset) else preset if preset not in ("siso", "mimo") else "recommended"
            c = cells.setdefault((r["split"], kind, effect), {"runs": 0, "detected": 0, "false_mpm": 0})
            c["runs"] += 1
            c["detected"] += bool(v["detected"])
            c["false_mpm"] += v["false_mpm"]
    order = sorted(cells, key=lambda k: (k[0] != fam.TUNING, k[1] != "recommended", k[2]))
    return [{"split": k[0], "presets": k[1], "effect": k[2], **cells[k]} for k in order]


def evidence_rows(runs: list) -> list:
    """Per split and evidence bin, over the linear change runs and the recommended presets:
    changes, detected, and read as a noise change."""
    rows = []
    for split in (fam.TUNING, fam.HELD_OUT):
        for lo, hi in zip(DETECTION_EVIDENCE_BINS[:-1], DETECTION_EVIDENCE_BINS[1:]):
            scored = [v for r in runs if r["split"] == split and r.get("evidence") is not None
                      and lo <= r["evidence"] < hi
                      for p, v in r["presets"].items() if not is_paper(p)]
            if scored:
                rows.append({"split": split, "bin": f"[{lo:g}, {hi:g})", "changes": len(scored),
                             "detected": sum(bool(v["detected"]) for v in scored),
                             "read_as_noise": sum(bool(v["read_as_noise"]) for v in scored)})
    return rows


def check_rows(runs: list) -> list:
    """Per split, over the recommended presets: change runs read as a noise change and how many
    of them the noise-alarm check names; control runs the check looked at and how many it told
    of a process change that did not happen."""
    rows = []
    for split in (fam.TUNING, fam.HELD_OUT):
        scored = [(r["expect"]["kind"], v) for r in runs if r["split"] == split
                  for p, v in r["presets"].items() if not is_paper(p) and "checks" in v]
        read = [v for kind, v in scored if kind != "none" and v["read_as_noise"]]
        controls = [v for kind, v in scored if kind == "none" and v["checks"]]
        if scored:
            rows.append({"split": split, "read_as_noise": len(read), "named": sum(v["check_named"] for v in read),
                         "controls_checked": len(controls), "false": sum(v["check_false"] for v in controls)})
    return rows


def _rate(k, n):
    return "-" if n == 0 else f"{k}/{n} ({100 * k / n:.0f}%)"


def format_table(study: dict) -> str:
    """Markdown tables: per family and preset (tuning families first, then held-out), then per
    effect pooled over the families of each split."""
    seeds = study["seeds"]
    lines = [f"scenario families, seeds {min(seeds)}-{max(seeds)}: {study['wall_seconds']:.0f} s wall on "
             f"{study['where']}{fam.variant_note(study)}", "",
             "| split | family | preset | detected | false MPM alarm | false noise alarm | mislocated only | "
             "detect refused | delay median (h) | delay p90 (h) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for split in (fam.TUNING, fam.HELD_OUT):
        for r in (r for r in study["rows"] if r["split"] == split):
            h = lambda s: "-" if s is None else f"{s / 3600:.2f}"  # noqa: E731
            lines.append(f"| {split} | {r['family']} | {r['preset']} | {_rate(r['detected'], r['changes'])} | "
                         f"{_rate(r['false_mpm'], r['runs'])} | {_rate(r['false_noise'], r['runs'])} | "
                         f"{_rate(r['mislocated'], r['changes'])} | "
                         f"{_rate(r['refused'], r['runs'])} | "
                         f"{h(r['delay_median_s'])} | {h(r['delay_p90_s'])} |")
    lines += ["", "| split | presets | effect | detected | false MPM alarm |", "| --- | --- | --- | --- | --- |"]
    for c in by_effect(study["runs"]):
        changed = c["effect"].split(":")[0] not in fam.CONTROL_EFFECTS
        lines.append(f"| {c['split']} | {c['presets']} | {c['effect']} | "
                     f"{_rate(c['detected'], c['runs']) if changed else '-'} | {_rate(c['false_mpm'], c['runs'])} |")
    ev = evidence_rows(study["runs"])
    if ev:
        lines += ["", "Linear changes by the record's evidence for them (the one-step likelihood-ratio gain of the "
                  "true change after its onset, with the true disturbance model, chi-square units); "
                  "recommended presets", "",
                  "| split | evidence | changes | detected | read as a noise change |", "| --- | --- | --- | --- | --- |"]
        lines += [f"| {r['split']} | {r['bin']} | {r['changes']} | {_rate(r['detected'], r['changes'])} | "
                  f"{_rate(r['read_as_noise'], r['changes'])} |" for r in ev]
    checks = check_rows(study["runs"])
    if checks:
        lines += ["", "The noise-alarm check (diagnose on the whole record when an output's noise alarm has no MPM "
                  "alarm beside it; recommended presets)", "",
                  "| split | changes read as a noise change | the check names the change | control runs checked | "
                  "the check names a process change |", "| --- | --- | --- | --- | --- |"]
        lines += [f"| {r['split']} | {r['read_as_noise']} | {_rate(r['named'], r['read_as_noise'])} | "
                  f"{r['controls_checked']} | {_rate(r['false'], r['controls_checked'])} |" for r in checks]
    return "\n".join(lines)
