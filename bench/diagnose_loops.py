"""``mpmpp identify`` then ``mpmpp diagnose`` on the stiction study's PI loops (2 h at 10 s):
how often diagnose names ``input_nonlinearity`` on sticking valves and on the confounders.

Records from studies/stiction_benchmark.py (TUNING: flow and level loops, Choudhury's valve;
HELD-OUT: pressure-like and slow-flow loops, He's valve; confounders: linear, aggressive
tuning, an external oscillation, a noisy linear valve). Per record the model comes from
``model_from_data`` (records it refuses as not identified are counted apart), then
``diagnose``; a stiction record is a hit when the top finding is ``input_nonlinearity``.
The error columns are the mean held-out one-step RMS before and after the valve update.

    PYTHONPATH=python python bench/diagnose_loops.py --seeds 3
"""
from __future__ import annotations

import argparse
import pathlib
import sys
from collections import defaultdict

import numpy as np
import pandas as pd

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "studies"))

import stiction_benchmark as sb  # noqa: E402

from mpmpp.diagnose import diagnose  # noqa: E402
from mpmpp.identify import model_from_data  # noqa: E402

CASES = (("stiction", 1.5), ("stiction", 3.0), ("linear", 0.0), ("aggressive", 0.0),
         ("external_oscillation", 0.0), ("noisy_valve", 0.0))


def frame(rec: dict) -> pd.DataFrame:
    n = len(rec["op"])
    return pd.DataFrame({"time": 10.0 * np.arange(n), "OP": rec["op"], "PV": rec["pv"] + 20.0,
                         "PV_sp": rec["sp"] + 20.0})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args()
    rows = defaultdict(lambda: {"records": 0, "refused": 0, "named": 0, "before": [], "after": []})
    for family, dynamics in (("tuning", sb.TUNING), ("held_out", sb.HELD_OUT)):
        for dyn in dynamics:
            for case, s in CASES:
                for seed in range(args.seeds):
                    rec = sb.make_record(family, dyn, case, s, 0.5 * s, 7001 + seed)
                    key = (family, dyn.name, case if case != "stiction" else f"stiction S={s:g}")
                    row = rows[key]
                    row["records"] += 1
                    data = frame(rec)
                    try:
                        model = model_from_data(data, ["OP"], ["PV"]).model
                    except ValueError:
                        row["refused"] += 1
                        continue
                    found = diagnose(model, data).findings
                    if found and found[0].effect == "input_nonlinearity":
                        row["named"] += 1
                        row["before"].append(found[0].error_before)
                        row["after"].append(found[0].error_after)
    print("| family | loop | case | records | not identified | input_nonlinearity | error before -> after |")
    print("|---|---|---|---|---|---|---|")
    for (family, loop, case), r in rows.items():
        err = (f"{np.mean(r['before']):.3f} -> {np.mean(r['after']):.3f}" if r["before"] else "")
        print(f"| {family} | {loop} | {case} | {r['records']} | {r['refused']} | {r['named']} | {err} |")


if __name__ == "__main__":
    main()
