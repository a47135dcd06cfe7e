"""Fit the confidence calibration map (diagnose/confidence.py) on the TUNING scenario families
only and write it as JSON (the package ships python/mpmpp/diagnose/confidence_map.json).

    python studies/calibrate_confidence.py [--seeds N] [--first-seed S] [--runs STUDY.json]
                                           -o MAP.json [--force]

Either runs the diagnosis study on the tuning families (seeds S..S+N-1, default 0-19: the
seeds docs/families.md reserves for choosing) or reads the runs of an earlier
``studies/diagnosis_families.py --json`` output; held-out runs are refused. Labels: a finding
is right when it names the scheduled effect where it happened (mpmpp.diagnosis_study).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mpmpp import families as fam
from mpmpp.diagnose.confidence import fit_map
from mpmpp.diagnosis_study import run_study
from mpmpp.io import atomic_output


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--first-seed", type=int, default=0)
    p.add_argument("--runs", help="runs from studies/diagnosis_families.py --json instead of running")
    p.add_argument("--workers", type=int)
    p.add_argument("-o", "--output", required=True, help="the map (JSON)")
    p.add_argument("--force", action="store_true", help="replace an existing map file")
    args = p.parse_args(argv)
    if Path(args.output).exists() and not args.force:
        p.error(f"-o {args.output}: exists (add --force to replace it)")
    tuning = [f.name for f in fam.FAMILIES if f.split == fam.TUNING]
    if args.runs:
        runs = json.loads(Path(args.runs).read_text())["runs"]
    else:
        runs = run_study(tuning, range(args.first_seed, args.first_seed + args.seeds), workers=args.workers)["runs"]
    held_out = sorted({r["family"] for r in runs if r["split"] != fam.TUNING})
    if held_out:
        print(f"calibrate_confidence: error: held-out families in the runs ({', '.join(held_out)})", file=sys.stderr)
        return 2
    findings = [f for r in runs for f in r["findings"]]
    calibration = fit_map(findings, [f["right"] for f in findings])
    calibration["fitted_on"] = {"families": sorted({r["family"] for r in runs}),
                                "seeds": sorted({r["seed"] for r in runs})}
    with atomic_output(args.output) as f:
        json.dump(calibration, f, indent=1)
    print(f"{calibration['findings']} findings ({calibration['right']} right) -> {args.output}")
    print("coefficients (standardised features): " + ", ".join(
        f"{n} {c:+.2f}" for n, c in zip(calibration["features"], calibration["coef"])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
