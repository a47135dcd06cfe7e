"""Hidden-effect suite for `mpmpp diagnose`: closed-loop MPC data from `mpmpp.simulate`
with one effect the model does not know, per effect of the docs/formats.md vocabulary, plus a
no-change control and a noise-level-only case, several seeds each.

    python studies/diagnose_eval.py [--seeds N] [--effects gain,delay,...] [--quiet]

Prints per case the top finding and, per effect, hits (top finding = effect, output, input,
onset within 1 h), misses and false findings (findings that do not match the hidden effect;
for the control and noise cases any process finding). The plant is a 2x2 paper-machine MD
loop (basis weight, moisture / stock flow, steam pressure) under MPC, 16 h at 5 s, changes at
6 h (9 h with --weak), plus one measured candidate column that only matters in the
unmodeled_input case. Effect sizes: STRONG / WEAK below.
"""
from __future__ import annotations

import argparse
import copy
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import mpmpp  # noqa: E402
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose  # noqa: E402

HOUR = 3600.0


def _tf(num, den, delay=0):
    return {"num": list(num), "den": list(den), "delay": delay}


BASE = {
    "name": "2x2 MD loop",
    "sample_time_s": 5.0,
    "inputs": ["stock_flow", "steam_pressure"],
    "outputs": ["basis_weight", "moisture"],
    "process": {
        "basis_weight": {"stock_flow": _tf([0.064], [1.0, -0.92], 12)},
        "moisture": {"stock_flow": _tf([0.015], [1.0, -0.95], 20),
                     "steam_pressure": _tf([-0.05], [1.0, -0.9], 8)},
    },
    "noise": {"basis_weight": {"num": [1.0, -0.2], "den": [1.0, 0.5]},
              "moisture": {"num": [1.0, 0.3], "den": [1.0, 0.4]}},
    "truth": {
        "sigma": {"basis_weight": 0.05, "moisture": 0.03},
        "extra": {"headbox_consistency": {"operating_point": 1.1, "sigma": 0.005,
                                          "noise": _tf([1.0], [1.0, -0.98])}},
    },
    "controller": {
        "prediction_horizon": 40, "control_horizon": 4,
        "cv": {"basis_weight": {"target": 80.0}, "moisture": {"target": 7.5}},
        "mv": {"stock_flow": {"target": 160.0, "move_weight": 0.01, "scale": 0.1, "min": 0.0, "max": 1000.0},
               "steam_pressure": {"target": 110.0, "move_weight": 0.01, "scale": 0.1, "min": 0.0,
                                  "max": 1000.0}},
    },
    "duration_s": 16 * HOUR,
}

# The two channels a per-channel effect is put on (alternating with the seed).
CHANNELS = [("basis_weight", "stock_flow"), ("moisture", "steam_pressure")]


# Effect sizes: the default suite and a weaker one (--weak) that shows where detection ends.
STRONG = {"onset": 6 * HOUR, "gain": (2.0, 0.4), "time_constant": 3.0, "delay": 10, "coupling": 0.035,
          "column": 0.4, "noise_den": [1.0, -0.6], "sigma": 2.0, "drift_per_h": 0.04, "actuator": 0.2}
WEAK = {"onset": 9 * HOUR, "gain": (1.5, 0.65), "time_constant": 2.0, "delay": 4, "coupling": 0.015,
        "column": 0.2, "noise_den": [1.0, -0.3], "sigma": 1.5, "drift_per_h": 0.015, "actuator": 0.1}
SIZE = STRONG


def case(effect: str, seed: int) -> tuple[dict, dict]:
    """(scenario, expected top finding) for one effect and seed."""
    sz = SIZE
    onset = sz["onset"]
    sc = copy.deepcopy(BASE)
    sc["seed"] = seed
    sc["name"] = f"{effect} seed {seed}"
    out, inp = CHANNELS[seed % 2]
    ev = {"time_s": onset}
    expect = {"effect": effect, "output": out, "input": inp, "onset_s": onset}
    if effect == "none":
        expect = None
    elif effect == "gain":
        sc["events"] = [{**ev, "type": "gain", "output": out, "input": inp, "factor": sz["gain"][0] if seed % 4 < 2 else sz["gain"][1]}]
    elif effect == "time_constant":
        sc["events"] = [{**ev, "type": "time_constant", "output": out, "input": inp,
                         "factor": sz["time_constant"]}]
    elif effect == "delay":
        d = sc["process"][out][inp]["delay"]
        sc["events"] = [{**ev, "type": "delay", "output": out, "input": inp, "delay": d + sz["delay"]}]
    elif effect == "missing_coupling":
        sc["truth"]["process"] = copy.deepcopy(sc["process"])
        sc["truth"]["process"]["basis_weight"]["steam_pressure"] = _tf([sz["coupling"]], [1.0, -0.9], 10)
        expect = {"effect": effect, "output": "basis_weight", "input": "steam_pressure", "onset_s": 0.0}
    elif effect == "unmodeled_input":
        target = CHANNELS[seed % 2][0]
        sc["truth"]["extra"]["headbox_consistency"]["affects"] = {target: _tf([sz["column"]], [1.0, -0.9], 6)}
        expect = {"effect": effect, "output": target, "input": "headbox_consistency", "onset_s": 0.0}
    elif effect == "noise_change":
        sc["events"] = [{**ev, "type": "noise", "output": out, "model": {"num": [1.0, 0.3], "den": sz["noise_den"]}}]
        expect = {"effect": effect, "output": out, "input": None, "onset_s": onset}
    elif effect == "noise_level":
        sigma = sc["truth"]["sigma"][out]
        sc["events"] = [{**ev, "type": "sigma", "output": out, "value": sz["sigma"] * sigma}]
        expect = {"effect": "noise_change", "output": out, "input": None, "onset_s": onset}
    elif effect == "output_drift":
        sc["events"] = [{**ev, "type": "drift", "output": out, "rate_per_s": sz["drift_per_h"] / HOUR}]
        expect = {"effect": effect, "output": out, "input": None, "onset_s": onset}
    elif effect == "input_nonlinearity":
        kind = "backlash" if seed % 4 < 2 else "deadband"
        sc["events"] = [{**ev, "type": "actuator", "input": inp, kind: sz["actuator"]}]
        expect = {"effect": effect, "output": None, "input": inp, "onset_s": onset}
    else:
        raise ValueError(f"unknown effect {effect}")
    return sc, expect


EFFECTS = ["none", "noise_level", "gain", "time_constant", "delay", "missing_coupling",
           "unmodeled_input", "noise_change", "output_drift", "input_nonlinearity"]


def matches(f, expect) -> bool:
    if f.effect != expect["effect"]:
        return False
    if expect["output"] is not None and f.output != expect["output"]:
        return False
    if expect["input"] is not None and f.input != expect["input"]:
        return False
    return abs(f.onset_s - expect["onset_s"]) <= HOUR


def model_of(sc: dict):
    """The controller's model of a scenario as a model file (noise models carry no delay there)."""
    doc = {k: sc[k] for k in ("name", "sample_time_s", "inputs", "outputs", "process")}
    doc["noise"] = {o: {"num": h["num"], "den": h["den"]} for o, h in sc.get("noise", {}).items()}
    return mpmpp.Model.from_json(json.dumps(doc))


def evaluate(effects, seeds, quiet=False):
    rows = {}
    timings = []
    for effect in effects:
        hits = misses = false = 0
        for seed in range(seeds):
            sc, expect = case(effect, seed)
            data = mpmpp.simulate(sc, seed=seed)
            t0 = time.perf_counter()
            res = diagnose(model_of(sc), data)
            timings.append(time.perf_counter() - t0)
            fs = res.findings
            if expect is None:
                ok = not fs
                n_false = len(fs)
            else:
                ok = bool(fs) and matches(fs[0], expect)
                n_false = sum(1 for f in fs if not matches(f, expect))
                if expect["effect"] == "noise_change":
                    n_false = sum(1 for f in fs if f.effect in PROCESS_EFFECTS) + sum(
                        1 for f in fs if f.effect not in PROCESS_EFFECTS and not matches(f, expect))
            hits += ok
            misses += not ok
            false += n_false
            if not quiet:
                top = (f"{fs[0].effect} {fs[0].output}<-{fs[0].input} at {fs[0].onset_s / HOUR:.1f} h "
                       f"(score {fs[0].score:.0f})") if fs else "no finding"
                print(f"  {effect:18s} seed {seed}: {'HIT ' if ok else 'MISS'} top: {top}; "
                      f"{len(fs)} finding(s)", flush=True)
        rows[effect] = (hits, misses, false)
    return rows, timings


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=4)
    p.add_argument("--effects", default=",".join(EFFECTS))
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--weak", action="store_true", help="smaller effects, onset at 9 h")
    args = p.parse_args(argv)
    global SIZE
    SIZE = WEAK if args.weak else STRONG
    rows, timings = evaluate(args.effects.split(","), args.seeds, args.quiet)
    print("\n| case | hits | misses | false findings |\n| --- | --- | --- | --- |")
    total_h = total_n = 0
    for effect, (h, m, f) in rows.items():
        print(f"| {effect} | {h}/{h + m} | {m} | {f} |")
        total_h += h
        total_n += h + m
    print(f"\nright top finding in {total_h}/{total_n} cases ({100 * total_h / max(total_n, 1):.0f} %); "
          f"diagnose time per 2x2, 16 h case: median {sorted(timings)[len(timings) // 2]:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
