"""What rows a historian lost cost ``mpmpp detect`` under the recommended presets: the same
family record scored complete and with one row lost (every column missing; the outputs' samples
alone with ``--outputs-only``) every ``--every-h`` hours, starting 17 samples in.

Per family: windows skipped, detections of the scheduled process change, runs with a false MPM
alarm, and runs whose alarm starts (every channel) differ from the complete record's. Nothing
is chosen on it; the 1 % cap on an input's lost samples per window was chosen on one tuning
window (cpp/src/residual_regression.cpp, kMaxLostInputShare).

    PYTHONPATH=python python studies/detect_gaps.py --seeds 10 --first-seed 100 --every-h 1
"""
from __future__ import annotations

import argparse

import numpy as np

from mpmpp import families as fam
from mpmpp.detect import channel_label, detect
from mpmpp.evaluate import nominal_model
from mpmpp.family_study import presets_for, score
from mpmpp.parallel import run_tasks
from mpmpp.simulate import simulate


def lose_rows(data, every_s: float, sample_time_s: float, columns):
    """``data`` with ``columns`` missing in one row per ``every_s`` seconds."""
    lost = data.copy()
    lost.loc[lost.index[17::max(1, int(round(every_s / sample_time_s)))], columns] = np.nan
    return lost


def run_seed(name: str, seed: int, every_h: float, outputs_only: bool) -> dict:
    spec, expect = fam.family(name).draw(seed)
    model = nominal_model(spec)
    data = simulate(spec)
    preset = next(p for p in presets_for(len(model.outputs)) if not p.startswith("paper"))
    out = {"family": name, "seed": seed, "expect": expect}
    columns = list(model.outputs) if outputs_only else [c for c in data.columns if c != "time"]
    for label, record in (("complete", data), ("lost", lose_rows(data, every_h * 3600, model.sample_time_s, columns))):
        try:
            det = detect(model, record, config=preset)
        except ValueError as exc:
            out[label] = {"refused": str(exc)}
            continue
        t0 = float(record["time"].iloc[0])
        alarms = {channel_label(c): [float(s) - t0 for s in det.alarm_starts(k)] for k, c in enumerate(det.channels)}
        out[label] = {**score(alarms, expect), "alarms": alarms, "skipped": int(det.windows["skipped"].sum()),
                      "windows": len(det.windows), "refused": None}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--first-seed", type=int, default=100)
    parser.add_argument("--every-h", type=float, default=1.0)
    parser.add_argument("--families", default=",".join(f.name for f in fam.FAMILIES if f.split == fam.TUNING))
    parser.add_argument("--outputs-only", action="store_true", help="lose the outputs' samples, not whole rows")
    parser.add_argument("--workers", type=int, default=None)
    args = parser.parse_args()
    names = args.families.split(",")
    tasks = [(n, s, args.every_h, args.outputs_only) for n in names for s in range(args.first_seed, args.first_seed + args.seeds)]
    runs, where = run_tasks(run_seed, tasks, workers=args.workers, progress=True)
    what = "the outputs' samples" if args.outputs_only else "a whole row"
    print(f"{what} lost every {args.every_h:g} h, seeds {args.first_seed}-{args.first_seed + args.seeds - 1}, on {where}\n")
    print("| family | record | refused | windows skipped | detected | false MPM alarm | alarms differ |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name in names:
        mine = [r for r in runs if r["family"] == name]
        for label in ("complete", "lost"):
            ok = [r[label] for r in mine if r[label]["refused"] is None]
            changes = [x for x in ok if x["detected"] is not None]
            differ = sum(r["lost"].get("alarms") != r["complete"].get("alarms") for r in mine) if label == "lost" else "-"
            print(f"| {name} | {label} | {len(mine) - len(ok)}/{len(mine)} | "
                  f"{sum(x['skipped'] for x in ok)}/{sum(x['windows'] for x in ok)} | "
                  f"{sum(x['detected'] for x in changes)}/{len(changes)} | {sum(x['false_mpm'] for x in ok)}/{len(ok)} | "
                  f"{differ} |")


if __name__ == "__main__":
    main()
