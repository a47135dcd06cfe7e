"""``mpmpp demo siso|mimo``: the paper's example end to end (simulate, detect, plot)."""
from __future__ import annotations

import json
import os
import sys
import time


def add_arguments(parser) -> None:
    parser.add_argument("example", choices=["siso", "mimo"], help="the paper's Section 5.1 or 5.2 example")
    parser.add_argument("--out", metavar="DIR", default=None,
                        help="write the figures (PNG), the data (CSV) and detect.json there "
                             "(default: out/demo-<example>)")
    parser.add_argument("--seed", type=int, default=0, help="simulation seed (default 0)")
    parser.add_argument("--json", action="store_true", help="print the detection result as one JSON document")


def _step(text: str, started: float) -> None:
    print(f"[{time.perf_counter() - started:5.1f} s] {text}", file=sys.stderr, flush=True)


def run(args) -> int:
    from .. import save_data
    from ..detect import detect, make_config
    from ..detect_plots import plot_detection, plot_profiles
    from ..evaluate import load_scenario, nominal_model
    from ..simulate import simulate

    started = time.perf_counter()
    scenario = load_scenario(f"paper_{args.example}")
    model = nominal_model(scenario)
    _step(f"simulating {scenario['name']} ({scenario['duration_s'] / 3600:g} h, seed {args.seed})", started)
    data = simulate(scenario, seed=args.seed)
    _step("training on the first {:g} h and monitoring every window".format(
        make_config(args.example, model).train_duration_s / 3600), started)
    result, detector = detect(model, data, None, args.example, return_detector=True)
    events = [(float(e["time_s"]), _event_label(e)) for e in scenario["events"]]
    if args.json:
        print(json.dumps(result.to_dict()))
    else:
        print(f"{scenario['name']}: trained on {detector.train_end_s / 3600:g} h; scheduled changes: " +
              "; ".join(f"{label} at {t / 3600:.2f} h" for t, label in events))
        print(result.alarm_table())
    out = args.out or os.path.join("out", f"demo-{args.example}")
    os.makedirs(out, exist_ok=True)
    _step(f"writing figures to {out}", started)
    plot_profiles(model, data, os.path.join(out, "profiles.png"), events, title=scenario["name"])
    plot_detection(result, os.path.join(out, "process_detection.png"), kinds=("process",), events=events,
                   title="Model-plant mismatch, per process channel")
    plot_detection(result, os.path.join(out, "noise_detection.png"), kinds=("noise",), events=events,
                   title="Disturbance changes, per output")
    save_data(os.path.join(out, "data.csv"), data)
    result.save_json(os.path.join(out, "detect.json"))
    detector.save(os.path.join(out, "detector.json"))
    _step("done", started)
    return 0


def _event_label(e: dict) -> str:
    if e["type"] == "noise":
        return f"noise model of {e['output']} changed"
    if e["type"] == "gain":
        return f"gain of {e['output']} <- {e['input']} x{e['factor']:g}"
    return f"{e['type']} change on {e.get('output', e.get('input'))}"
