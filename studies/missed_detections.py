"""Where the recommended presets' missed detections go, and what other alarm rules would have
given on the same windows (docs/families.md "Where the missed detections go").

    python studies/missed_detections.py [--families A,B] [--seeds N] [--first-seed S]
                                        [--workers K] [--rule LEVEL/THRESHOLD[/N_T] ...]
                                        [--siso CONFIG] [--mimo CONFIG]

Each run of a family is simulated once and detected with the recommended preset of its size
(``siso`` / ``mimo``, or the config given for that size: a preset name or inline JSON). Every missed process change (no MPM alarm on an expected channel at or
after the change) is put in one class:

* short: fewer than the alarm count of windows lie wholly after the change (too little
  record after the onset);
* never: no window touching the changed part of the record reaches p < window_significance on
  an expected channel (near: the best of them reaches ten times the level);
* sparse: some such windows are negative, but never alarm_count of n_T at once (s < s_T).

A window's p-value is recovered from its score, log10(p / window_significance), so the same
windows are re-scored under other levels, thresholds and inspection lengths (``--rule``; the
Wald test itself does not depend on them): detected changes and runs with a false MPM alarm, as
studies/detection_families.py counts them. The re-scoring is checked to reproduce detect's
own alarms at the preset's rule.
"""
from __future__ import annotations

import argparse
import collections
import json
import sys

import numpy as np

from mpmpp import families as fam
from mpmpp.detect import channel_label, detect
from mpmpp.evaluate import nominal_model
from mpmpp.family_study import presets_for, score
from mpmpp.parallel import run_tasks
from mpmpp.simulate import simulate

CLASSES = ("detected", "short", "never", "near", "sparse")


def window_p_values(name: str, seed: int, configs: dict, channel_switch: str = "replay") -> dict:
    """One run: per-window log10 p of every process channel, window times from the record's
    start, and detect's own MPM alarm starts; ``refused`` when detect refuses the data.
    configs: {"siso": config, "mimo": config}, by the family's size."""
    family = fam.family(name)
    spec, expect = family.draw(seed, channel_switch=channel_switch)
    model = nominal_model(spec)
    data = simulate(spec)
    run = {"family": name, "seed": int(seed), "expect": expect}
    try:
        config = configs[presets_for(family.size)[0]]
        result, detector = detect(model, data, config=config, return_detector=True)
    except ValueError as exc:
        return {**run, "refused": str(exc)}
    config = detector.config
    t0 = float(data["time"].iloc[0])
    process = [k for k, c in enumerate(result.channels) if c["kind"] == "process"]
    return {**run, "refused": None, "significance": config.window_significance,
            "n_T": config.inspection_windows(), "alarm_count": config.alarm_count(),
            "start_s": result.windows["start_s"].to_numpy() - t0, "end_s": result.windows["end_s"].to_numpy() - t0,
            "training": result.windows["training"].to_numpy(bool),
            "labels": [channel_label(result.channels[k]) for k in process],
            "log10_p": result.scores[:, process] + np.log10(config.window_significance),
            "alarms": {channel_label(result.channels[k]): list(result.alarm_starts(k) - t0) for k in process}}


def rule_alarms(run: dict, level: float, threshold: float, n_T: int) -> dict:
    """MPM alarm starts per process channel when a window is negative at p < level and an alarm
    starts once ceil(threshold n_T) of the last n_T windows are (eq. 23; training windows count
    as not negative, as in Detector::monitor)."""
    k = max(1, int(np.ceil(threshold * n_T - 1e-9)))
    negative = (run["log10_p"] < np.log10(level)) & ~run["training"][:, None]
    counts = np.apply_along_axis(lambda x: np.convolve(x, np.ones(n_T, int))[: len(x)], 0, negative.astype(int))
    on = counts >= k
    started = on & ~np.vstack([np.zeros((1, on.shape[1]), bool), on[:-1]])
    return {label: list(run["end_s"][started[:, c]]) for c, label in enumerate(run["labels"])}


def expected_columns(run: dict) -> list:
    e = run["expect"]
    labels = {channel_label({"kind": "process", "output": o, "input": i}) for o, i in e["channels"]}
    return [c for c, label in enumerate(run["labels"]) if label in labels]


def effect_name(expect: dict) -> str:
    return expect["effect"] + (f":{expect['nonlinearity']}" if "nonlinearity" in expect else "")


def classify(run: dict) -> str:
    """detected / short / never / sparse (module docstring) for a change run detect did not refuse;
    "near" is a "never" whose best window reaches p < 10 window_significance."""
    if score(run["alarms"], run["expect"])["detected"]:
        return "detected"
    onset = run["expect"]["onset_s"]
    monitored = ~run["training"]
    if np.sum(monitored & (run["start_s"] >= onset)) < run["alarm_count"]:
        return "short"
    touched = run["log10_p"][monitored & (run["end_s"] > onset)][:, expected_columns(run)]
    best = np.nanmin(touched) if np.isfinite(touched).any() else np.inf
    level = np.log10(run["significance"])
    return "sparse" if best < level else "near" if best < level + 1 else "never"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    fam.add_study_arguments(p, "family", first_seed=0)
    p.add_argument("--rule", action="append", default=[], metavar="LEVEL/THRESHOLD[/N_T]",
                   help="also re-score the windows with this window level, threshold and n_T")
    for size in ("siso", "mimo"):
        p.add_argument(f"--{size}", default=size, metavar="CONFIG",
                       help=f"detector config of {size} families: a preset name or inline JSON (default {size})")
    args = p.parse_args(argv)
    names, seeds = fam.study_selection(p, args)
    configs = {}
    for size in ("siso", "mimo"):
        given = getattr(args, size)
        try:
            configs[size] = json.loads(given) if given.lstrip().startswith("{") else given
        except json.JSONDecodeError as exc:
            p.error(f"--{size}: not valid JSON ({exc})")
    names = names or [f.name for f in fam.FAMILIES if f.split == fam.TUNING]
    rules = []
    for text in args.rule:
        try:
            parts = [float(x) for x in text.split("/")]
            rules.append((parts[0], parts[1], int(parts[2]) if len(parts) > 2 else None))
        except (ValueError, IndexError):
            p.error(f"--rule {text!r}: expected LEVEL/THRESHOLD[/N_T], e.g. 0.003/0.5/24")
    runs, _ = run_tasks(window_p_values, [(n, s, configs, args.channel_switch) for n in names for s in seeds],
                        args.scheduler, args.workers, True, unit="runs")
    runs = [r for r in runs if r["refused"] is None]
    for r in runs:  # the NumPy alarm rule must be detect's own at the preset's values
        mine = rule_alarms(r, r["significance"], r["alarm_count"] / r["n_T"], r["n_T"])
        if any(not np.allclose(sorted(mine[k]), sorted(r["alarms"][k])) for k in mine):
            raise SystemExit(f"missed_detections: re-scoring differs from detect on {r['family']} seed {r['seed']}")
    table = collections.defaultdict(collections.Counter)
    for r in runs:
        if r["expect"]["kind"] != "none":
            table[effect_name(r["expect"])][classify(r)] += 1
    print(f"families {', '.join(names)}; seeds {min(seeds)}-{max(seeds)}; configs {args.siso} / {args.mimo}\n")
    print("| effect | changes | detected | missed: short record | missed: no window p < level (best p >= 10 level) "
          "| missed: no window p < level (best p < 10 level) | missed: some negative windows, s < s_T |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for effect in sorted(table):
        c = table[effect]
        print(f"| {effect} | {sum(c.values())} | " + " | ".join(str(c[k]) for k in CLASSES) + " |")
    total = sum(table.values(), collections.Counter())
    print(f"| all | {sum(total.values())} | " + " | ".join(str(total[k]) for k in CLASSES) + " |")
    if rules:
        print("\n| level | threshold | n_T | detected | runs with a false MPM alarm | most in one family |")
        print("| --- | --- | --- | --- | --- | --- |")
    for level, threshold, n_T in rules:
        detected = changes = 0
        false = collections.Counter()
        for r in runs:
            s = score(rule_alarms(r, level, threshold, n_T or r["n_T"]), r["expect"])
            false[r["family"]] += s["false_mpm"]
            if s["detected"] is not None:
                changes += 1
                detected += s["detected"]
        print(f"| {level:g} | {threshold:g} | {n_T or 'preset'} | {detected}/{changes} | {sum(false.values())}/{len(runs)} "
              f"| {max(false.values())} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
