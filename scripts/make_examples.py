"""Writes the example cases in examples/: for each, the model a controller uses (model.json),
routine closed-loop operating data (data.csv) and what is hidden in the data (answer.json),
plus the scenario the project's simulator ran (scenario.json).

    PYTHONPATH=python python scripts/make_examples.py [OUT_DIR]   (default: examples)

Each case is a closed loop under the simulator's MPC, which uses the nominal model, around a
true plant that differs from it by one effect. Seeded: the same seed gives the same data on
every platform (docs/scenario.md). The noise levels and effect sizes are those of typical paper
machine loops (sigma 0.05 on weights, 0.03 on moisture, a 2x gain), not tuned to any detector.
Values are written with 6 significant digits, as a historian export would hold them.
"""
from __future__ import annotations

import copy
import json
import sys
from pathlib import Path

import numpy as np

from mpmpp.scenarios import HOUR, tf_spec

TS = 5.0
SIGNIFICANT_DIGITS = 6


def _mv(target, max_move, move_weight):
    # Paper Table 2's MV tuning (weights on the MV in units of 0.1, as in scenarios.paper_siso),
    # with move weights that give MV moves of the size seen on such loops (MV standard
    # deviation about 0.025 at these noise levels; Table 2's 0.01 moves twice as much).
    return {"target": target, "target_weight": 1.0, "move_weight": move_weight, "deviation_weight": 0.0,
            "minmax_weight": 1.0, "min": 0.0, "max": 3 * target, "max_move": max_move, "scale": 0.1}


def _cv(target):
    return {"target": target, "target_weight": 1.0, "minmax_weight": 1.0}


# 1x1: dry weight <- stock flow; the process gain doubles at 8 h.
_SISO = {
    "name": "dry weight loop",
    "sample_time_s": TS,
    "inputs": ["stock_flow"],
    "outputs": ["dry_weight"],
    "process": {"dry_weight": {"stock_flow": tf_spec([0.063], [1.0, -0.93], 14)}},
    "noise": {"dry_weight": tf_spec([1.0, -0.4], [1.0, 0.5])},
    "truth": {"sigma": {"dry_weight": 0.05}},
    "controller": {"prediction_horizon": 40, "control_horizon": 4,
                   "cv": {"dry_weight": _cv(52.0)}, "mv": {"stock_flow": _mv(140.0, 0.1667, 0.05)}},
    "duration_s": 16 * HOUR,
    "seed": 11,
    "events": [{"time_s": 8 * HOUR, "type": "gain", "output": "dry_weight", "input": "stock_flow",
                "factor": 2.0}],
}

# 2x2: basis weight and moisture <- stock flow and steam pressure (the model has no basis weight
# <- steam pressure channel).
_MIMO_MODEL = {
    "sample_time_s": TS,
    "inputs": ["stock_flow", "steam_pressure"],
    "outputs": ["basis_weight", "moisture"],
    "process": {"basis_weight": {"stock_flow": tf_spec([0.064], [1.0, -0.92], 12)},
                "moisture": {"stock_flow": tf_spec([0.015], [1.0, -0.95], 20),
                             "steam_pressure": tf_spec([-0.05], [1.0, -0.9], 8)}},
    "noise": {"basis_weight": tf_spec([1.0, -0.2], [1.0, 0.5]),
              "moisture": tf_spec([1.0, 0.3], [1.0, 0.4])},
    "controller": {"prediction_horizon": 40, "control_horizon": 4,
                   "cv": {"basis_weight": _cv(80.0), "moisture": _cv(7.5)},
                   "mv": {"stock_flow": _mv(160.0, 0.1667, 0.03), "steam_pressure": _mv(110.0, 1.0, 0.03)}},
}
_MIMO_SIGMA = {"basis_weight": 0.05, "moisture": 0.03}

_COUPLING = copy.deepcopy(_MIMO_MODEL) | {
    "name": "basis weight and moisture",
    "duration_s": 14 * HOUR,
    "seed": 12,
    "events": [],
}
_COUPLING["truth"] = {"sigma": _MIMO_SIGMA,
                      "process": copy.deepcopy(_MIMO_MODEL["process"])}
# Steam pressure acts on basis weight (gain 0.35) from the start; the model says it does not.
_COUPLING["truth"]["process"]["basis_weight"]["steam_pressure"] = tf_spec([0.035], [1.0, -0.9], 10)

_NOISE = copy.deepcopy(_MIMO_MODEL) | {
    "name": "basis weight and moisture",
    "truth": {"sigma": _MIMO_SIGMA},
    "duration_s": 16 * HOUR,
    "seed": 13,
    # Only the disturbance changes (its pole moves from -0.4 to +0.6: slower, larger
    # wander); the process model stays right.
    "events": [{"time_s": 7 * HOUR, "type": "noise", "output": "moisture",
                "model": tf_spec([1.0, 0.3], [1.0, -0.6])}],
}

EXAMPLES = {"siso_gain_change": _SISO, "mimo_missing_coupling": _COUPLING, "mimo_noise_change": _NOISE}


def answer(scenario: dict) -> dict:
    """The hidden effects, in the findings format of docs/formats.md, read off the scenario:
    truth channels the model lacks, then the events in time order."""
    from mpmpp.scenario import parse_transfer_function

    findings = []
    for output, row in scenario.get("truth", {}).get("process", {}).items():
        for input_, spec in row.items():
            if input_ not in scenario["process"].get(output, {}):
                g = parse_transfer_function(spec, f"truth.process.{output}.{input_}", scenario["sample_time_s"])
                findings.append({"effect": "missing_coupling", "output": output, "input": input_,
                                 "onset_s": 0.0, "gain": round(g.dc_gain(), 12)})
    for event in sorted(scenario["events"], key=lambda e: e["time_s"]):
        if event["type"] == "gain":
            findings.append({"effect": "gain", "output": event["output"], "input": event["input"],
                             "onset_s": float(event["time_s"]), "ratio": float(event["factor"])})
        elif event["type"] in ("noise", "sigma"):
            findings.append({"effect": "noise_change", "output": event["output"],
                             "onset_s": float(event["time_s"])})
        else:
            raise ValueError(f"{scenario['name']}: no answer written for a {event['type']!r} event")
    return {"findings": findings}


def _round(x: np.ndarray) -> np.ndarray:
    return np.array([float(f"{v:.{SIGNIFICANT_DIGITS}g}") for v in x])


def write_example(name: str, out_dir: Path) -> Path:
    import mpmpp
    from mpmpp.evaluate import nominal_model
    from mpmpp.io import atomic_output

    scenario = EXAMPLES[name]
    folder = out_dir / name
    folder.mkdir(parents=True, exist_ok=True)
    model = nominal_model(scenario)
    data = mpmpp.simulate(scenario)
    if data.attrs["failed_solves"]:
        raise RuntimeError(f"{name}: {data.attrs['failed_solves']} MPC solves did not converge")
    # What a historian export holds: the MV commands and the measured CVs (setpoints constant).
    data = data[["time", *model.inputs, *model.outputs]].copy()
    for column in [*model.inputs, *model.outputs]:
        data[column] = _round(data[column].to_numpy())
    mpmpp.save_model(model, folder / "model.json")
    mpmpp.save_data(folder / "data.csv", data)
    for file, doc in (("answer.json", answer(scenario)), ("scenario.json", scenario)):
        with atomic_output(folder / file) as f:
            f.write(json.dumps(doc, indent=2) + "\n")
    return folder


def main(argv: list[str]) -> int:
    out_dir = Path(argv[0]) if argv else Path(__file__).resolve().parents[1] / "examples"
    for name in EXAMPLES:
        print(f"wrote {write_example(name, out_dir)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
