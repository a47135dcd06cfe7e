"""``mpmpp identify`` then ``mpmpp compare`` on the stiction study's PI loops (2 h at 10 s): how
often compare's hysteresis check (hysteresis_test.py) flags the valve, on sticking valves and on
the confounders, beside its linear input cross-correlation test.

Records from studies/stiction_benchmark.py, as bench/diagnose_loops.py takes them (TUNING:
flow, level, level with a load and temperature-like loops, Choudhury's valve; HELD-OUT:
pressure-like, slow-flow, analyser-like and surge-tank loops, He's valve; confounders: linear,
aggressive tuning, an external oscillation, a noisy linear valve). Records ``identify`` refuses
are counted apart. Per family and case: records flagged by the hysteresis check / records, and
by the cross-correlation test (a positive-lag violation with the OP); per split the recall,
false-call rate, precision and accuracy at the real records' mix (35 sticking, 45 not).

With ``--scenario-families A,B`` it runs compare with the nominal model on those scenario
families instead (mpmpp.families; every effect a family schedules: the controls, linear changes
and valve changes with an onset inside the record) and counts the records the check flags per
effect: a linear change or a disturbance must not be read as a valve.

    PYTHONPATH=python python studies/compare_hysteresis.py --seeds 4 [--first-seed 7001] [--families tuning]
    PYTHONPATH=python python studies/compare_hysteresis.py --scenario-families pi_siso,mpc_2x2 --seeds 5 --first-seed 0
"""
from __future__ import annotations

import argparse
import pathlib
import sys
from collections import defaultdict

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "studies"))
sys.path.insert(0, str(ROOT / "bench"))

from diagnose_loops import at_real_mix, tallied_records  # noqa: E402

from mpmpp import families as scenario_families  # noqa: E402
from mpmpp.compare import compare  # noqa: E402
from mpmpp.evaluate import nominal_model  # noqa: E402
from mpmpp.simulate import simulate  # noqa: E402

EFFECTS = scenario_families.CONTROL_EFFECTS + scenario_families.MPM_EFFECTS


def scenario_table(names: list[str], seeds: range) -> None:
    """Records the check flags on the scenario families, per split and effect (a valve change
    by its kind)."""
    rows = defaultdict(lambda: [0, 0])
    for name in names:
        family = scenario_families.family(name)
        for seed in seeds:
            for effect in EFFECTS:
                if effect not in family.effects:
                    continue
                spec, truth = family.draw(seed, effect=effect)
                result = compare(nominal_model(spec), simulate(spec))
                what = effect if effect != "input_nonlinearity" else f"valve: {truth['nonlinearity']}"
                row = rows[(family.split, what)]
                row[0] += any(h.significant for out in result.outputs for h in out.hysteresis)
                row[1] += 1
    print("| split | effect | records flagged |")
    print("| --- | --- | --- |")
    for (split, what), (flagged, total) in sorted(rows.items()):
        print(f"| {split} | {what} | {flagged}/{total} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=4)
    parser.add_argument("--first-seed", type=int, default=7001,
                        help="records' first seed (7001-7004 chose the widths and level; report on others)")
    parser.add_argument("--families", default="tuning,held_out", help="comma-separated: tuning, held_out")
    parser.add_argument("--scenario-families", help="comma-separated scenario families (mpmpp.families) instead")
    args = parser.parse_args()
    if args.scenario_families:
        scenario_table(args.scenario_families.split(","), range(args.first_seed, args.first_seed + args.seeds))
        return
    rows = defaultdict(lambda: {"records": 0, "refused": 0, "hysteresis": 0, "cross": 0})
    for row, data, model in tallied_records(rows, args.families.split(","), args.seeds, args.first_seed):
        out = compare(model, data).outputs[0]
        row["hysteresis"] += any(c.significant for c in out.hysteresis)
        row["cross"] += any(c.positive_lag_violations for c in out.cross if c.column == "OP")
    print("| split | loop | case | records | refused | hysteresis flagged | OP cross-correlation flagged |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for (family, loop, case), r in sorted(rows.items()):
        print(f"| {family} | {loop} | {case} | {r['records']} | {r['refused']} | {r['hysteresis']} | {r['cross']} |")
    print()
    print("| split | test | recall | false-call rate | precision at the real mix | accuracy at the real mix |")
    print("| --- | --- | --- | --- | --- | --- |")
    for family in args.families.split(","):
        for test in ("hysteresis", "cross"):
            sticking = [r for (f, _, c), r in rows.items() if f == family and c.startswith("stiction")]
            others = [r for (f, _, c), r in rows.items() if f == family and not c.startswith("stiction")]
            recall = sum(r[test] for r in sticking) / sum(r["records"] for r in sticking)
            false = sum(r[test] for r in others) / sum(r["records"] for r in others)
            precision, accuracy = at_real_mix(recall, false)
            print(f"| {family} | {test} | {recall:.2f} | {false:.2f} | {precision:.2f} | {accuracy:.2f} |")


if __name__ == "__main__":
    main()
