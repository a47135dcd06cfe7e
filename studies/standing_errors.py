"""Hand-written models wrong from the start, on historian-length PI-loop records: does
``diagnose`` name the model's own error, and does it stay quiet when the model is right?

Loops (tests/python/pi_loop.py, a plain NumPy PI-loop simulator, exact ZOH with a fractional
dead time), 2 h at 10 s (751 rows; ``--rows``), routine operation (disturbances only) and with
setpoint steps. ``--loops tuning``: flow / level-like / pressure-like (pi_loop.LOOPS), where
the short-record rule of diagnose/pipeline._without_unconfirmed_standing_changes was chosen
(seeds 1-8); ``--loops held-out``: temperature-like, analyser-like (dead time longer than the
lag), fast flow and a reverse-acting slow pressure loop, used for reporting only. The model file is
the FOPTD a user writes with one parameter off: gain x0.5, x0.625, x1.6, x2 or time constant
x0.5, x2 (the other parameters right), or every parameter right (the control). No noise model,
as with hand-written models.

Per case: "named" is a linear channel finding present from the first row whose update removes
at least a quarter of the channel's step-response error against the plant
(diagnosis_study.standing_error_named); "withheld" counts runs where diagnose's note says a
finding from the first row was withheld (pipeline._without_unconfirmed_standing_changes);
"false" counts control runs with any process finding.

``--later``: the same models on records (setpoint steps) whose plant gain doubles or halves
one hour in (``pi_loop.simulate``'s ``gain_change``), or stays: "later change named" is a gain
finding dated within half an hour of the change, in its direction; with no change, "dated
finding" counts runs with any process finding dated inside the record (false).

    PYTHONPATH=python python studies/standing_errors.py --seeds 8 --first-seed 1
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))

import pi_loop  # noqa: E402

from mpmpp import _core  # noqa: E402
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose  # noqa: E402
from mpmpp.diagnosis_study import standing_error_named  # noqa: E402
from mpmpp.parallel import run_tasks  # noqa: E402

TS = 10.0
# (parameter, factor): the model's error; ("none", 1.0) is the control.
ERRORS = (("gain", 0.5), ("gain", 0.625), ("gain", 1.6), ("gain", 2.0),
          ("time_constant", 0.5), ("time_constant", 2.0), ("none", 1.0))


# Held-out loops: other gains, lags, dead times and disturbances than pi_loop.LOOPS.
HELD_OUT_LOOPS = (
    pi_loop.Loop("temperature", 0.6, 300.0, 60.0, 0.02, 0.95),
    pi_loop.Loop("analyser", 1.2, 120.0, 150.0, 0.03, 0.8),
    pi_loop.Loop("fast flow", 2.5, 12.0, 4.0, 0.08, 0.5),
    pi_loop.Loop("slow pressure", -0.9, 600.0, 45.0, 0.05, 0.98),
)
LOOP_SETS = {"tuning": pi_loop.LOOPS, "held-out": HELD_OUT_LOOPS}


def _model(g) -> _core.Model:
    return _core.Model("loop", TS, ["OP"], ["PV"], {"PV": {"OP": g}})


def plant_model(loop: pi_loop.Loop) -> _core.Model:
    """The simulator's exact ZOH discretisation (its fractional dead time included)."""
    a, b0, b1, d = pi_loop.foptd_coefficients(loop, TS)
    return _model(_core.TransferFunction([b0, b1], [1.0, -a], d))


def hand_written(loop: pi_loop.Loop, parameter: str, factor: float) -> _core.Model:
    gain = loop.gain * (factor if parameter == "gain" else 1.0)
    tau = loop.time_constant_s * (factor if parameter == "time_constant" else 1.0)
    return _model(_core.TransferFunction.from_foptd(gain, tau, loop.dead_time_s, TS))


def run_case(loop_name: str, parameter: str, factor: float, seed: int, steps: bool, rows: int) -> dict:
    loop = next(lp for lp in pi_loop.LOOPS + HELD_OUT_LOOPS if lp.name == loop_name)
    model, plant = hand_written(loop, parameter, factor), plant_model(loop)
    data = pi_loop.simulate(loop, seed, rows=rows, ts=TS, setpoint_steps=steps)
    result = diagnose(model, data)
    start = float(data["time"].iloc[0])
    process = [f for f in result.findings if f.effect in PROCESS_EFFECTS]
    standing = [f for f in process if f.onset_s <= start and f.effect in ("gain", "time_constant", "delay")]
    return {"loop": loop_name, "parameter": parameter, "factor": factor, "seed": seed, "steps": steps,
            "named": any(standing_error_named(model, plant, f) for f in standing),
            "process_findings": [f"{f.effect} @ {f.onset_s - start:g} s" for f in process],
            "withheld": sum("withheld" in n for n in result.notes)}


LATER_ROW = 360                 # one hour in at 10 s
LATER_CHANGES = (2.0, 0.5, 1.0)  # plant gain factor from LATER_ROW on (1.0: no change)


def run_later_case(loop_name: str, parameter: str, factor: float, seed: int, change: float, rows: int) -> dict:
    loop = next(lp for lp in pi_loop.LOOPS + HELD_OUT_LOOPS if lp.name == loop_name)
    data = pi_loop.simulate(loop, seed, rows=rows, ts=TS, setpoint_steps=True,
                            gain_change=None if change == 1.0 else (LATER_ROW, change))
    result = diagnose(hand_written(loop, parameter, factor), data)
    start = float(data["time"].iloc[0])
    dated = [f for f in result.findings if f.effect in PROCESS_EFFECTS and f.onset_s > start]
    onset_s = start + LATER_ROW * TS
    named = change != 1.0 and any(
        f.effect == "gain" and abs(f.onset_s - onset_s) <= 1800.0 and (f.estimate["gain_ratio"] > 1) == (change > 1)
        for f in dated)
    return {"parameter": parameter, "factor": factor, "change": change, "named": named, "dated": bool(dated)}


def later_summary(runs: list) -> list[str]:
    out = ["| model error | plant gain at 1 h | runs | later change named | dated finding |",
           "| --- | --- | --- | --- | --- |"]
    for parameter, factor in ERRORS:
        for change in LATER_CHANGES:
            rs = [r for r in runs if (r["parameter"], r["factor"], r["change"]) == (parameter, factor, change)]
            if not rs:
                continue
            label = "none" if parameter == "none" else f"{parameter} x{factor:g}"
            named = "-" if change == 1.0 else f"{sum(r['named'] for r in rs)}/{len(rs)}"
            out.append(f"| {label} | {'unchanged' if change == 1.0 else f'x{change:g}'} | {len(rs)} | {named} | "
                       f"{sum(r['dated'] for r in rs)}/{len(rs)} |")
    return out


def summary(runs: list) -> list[str]:
    out = ["| model error | operation | runs | named | any process finding | runs with a finding withheld |",
           "| --- | --- | --- | --- | --- | --- |"]
    for parameter, factor in ERRORS:
        for steps in (True, False):
            rs = [r for r in runs if r["parameter"] == parameter and r["factor"] == factor and r["steps"] == steps]
            if not rs:
                continue
            label = "none (control)" if parameter == "none" else f"{parameter} x{factor:g}"
            named = "-" if parameter == "none" else f"{sum(r['named'] for r in rs)}/{len(rs)}"
            out.append(f"| {label} | {'setpoint steps' if steps else 'routine'} | {len(rs)} | {named} | "
                       f"{sum(bool(r['process_findings']) for r in rs)}/{len(rs)} | "
                       f"{sum(r['withheld'] > 0 for r in rs)}/{len(rs)} |")
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=4)
    p.add_argument("--first-seed", type=int, default=1)
    p.add_argument("--rows", type=int, default=751, help="record length in rows at 10 s (default 751 = 2.1 h)")
    p.add_argument("--loops", choices=sorted(LOOP_SETS), default="tuning")
    p.add_argument("--later", action="store_true", help="records whose plant gain changes one hour in")
    p.add_argument("--workers", type=int, default=None)
    args = p.parse_args(argv)
    loops = LOOP_SETS[args.loops]
    started = time.perf_counter()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    if args.later:
        tasks = [(lp.name, parameter, factor, seed, change, args.rows) for lp in loops
                 for parameter, factor in ERRORS for seed in seeds for change in LATER_CHANGES]
        runs, where = run_tasks(run_later_case, tasks, None, args.workers, True, unit="runs")
    else:
        tasks = [(lp.name, parameter, factor, seed, steps, args.rows) for lp in loops
                 for parameter, factor in ERRORS for seed in seeds for steps in (True, False)]
        runs, where = run_tasks(run_case, tasks, None, args.workers, True, unit="runs")
    print(f"{args.loops} loops {', '.join(lp.name for lp in loops)}; seeds {args.first_seed}-"
          f"{args.first_seed + args.seeds - 1}; {args.rows} rows at {TS:g} s; "
          f"{time.perf_counter() - started:.0f} s wall on {where}\n")
    print("\n".join(later_summary(runs) if args.later else summary(runs)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
