"""Fit the confidence calibration map (diagnose/confidence.py) on the TUNING scenario families
only and write it as JSON (the package ships python/mpmpp/diagnose/confidence_map.json).

    python studies/calibrate_confidence.py [--seeds N] [--first-seed S] [--runs STUDY.json ...]
                                           -o MAP.json [--force] [--cross-fit]
                                           [--regularisation C] [--leave-family-out]

Either runs the diagnosis study on the tuning families (seeds S..S+N-1, default 0-19: the
seeds docs/families.md reserves for choosing) or reads the runs of an earlier
``studies/diagnosis_families.py --json`` output; held-out runs are refused. Labels: a finding
is right when it names the scheduled effect where it happened (mpmpp.diagnosis_study).
Findings that carry their own calibration (the valve fit's) are neither fitted nor rescored.
``--cross-fit`` also prints the reliability of maps fitted on half of the seeds (even / odd)
scored on the other half, so no finding is scored by a map fitted on it.
``--leave-family-out`` prints, for each penalty of REGULARISATIONS, the log-loss and the
reliability at >= 0.9 of maps fitted without one tuning family scored on it: the held-out
families are other families, not other seeds, and that is how a penalty would be chosen
(the shipped map's is REGULARISATION; docs/diagnose.md, "Confidence").
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from mpmpp import families as fam
from mpmpp.diagnose.confidence import fit_map, probability
from mpmpp.diagnosis_study import reliability_by_effect, reliability_rows, run_study
from mpmpp.io import atomic_output


REGULARISATION = 1.0
REGULARISATIONS = (0.01, 0.03, 0.1, 0.3, 1.0, 3.0)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=20)
    p.add_argument("--first-seed", type=int, default=0)
    p.add_argument("--runs", nargs="+", help="runs from studies/diagnosis_families.py --json instead of running")
    p.add_argument("--workers", type=int)
    p.add_argument("-o", "--output", required=True, help="the map (JSON)")
    p.add_argument("--force", action="store_true", help="replace an existing map file")
    p.add_argument("--cross-fit", action="store_true", help="print the reliability of half-seed maps on the other half")
    p.add_argument("--regularisation", type=float, default=REGULARISATION, help="the map's L2 penalty C")
    p.add_argument("--leave-family-out", action="store_true",
                   help="print the log-loss of maps fitted without each family, per penalty")
    args = p.parse_args(argv)
    if Path(args.output).exists() and not args.force:
        p.error(f"-o {args.output}: exists (add --force to replace it)")
    tuning = [f.name for f in fam.FAMILIES if f.split == fam.TUNING]
    if args.runs:
        runs = [r for path in args.runs for r in json.loads(Path(path).read_text())["runs"]]
    else:
        runs = run_study(tuning, range(args.first_seed, args.first_seed + args.seeds), workers=args.workers)["runs"]
    held_out = sorted({r["family"] for r in runs if r["split"] != fam.TUNING})
    if held_out:
        print(f"calibrate_confidence: error: held-out families in the runs ({', '.join(held_out)})", file=sys.stderr)
        return 2
    findings = [f for r in runs for f in r["findings"] if not f.get("calibrated")]
    calibration = fit_map(findings, [f["right"] for f in findings], args.regularisation)
    calibration["fitted_on"] = {"families": sorted({r["family"] for r in runs}),
                                "seeds": sorted({r["seed"] for r in runs}),
                                "regularisation": args.regularisation}
    with atomic_output(args.output) as f:
        json.dump(calibration, f, indent=1)
    print(f"{calibration['findings']} findings ({calibration['right']} right) -> {args.output}")
    print("coefficients (standardised features): " + ", ".join(
        f"{n} {c:+.2f}" for n, c in zip(calibration["features"], calibration["coef"])))
    if args.cross_fit:
        print(cross_fitted_reliability(runs, args.regularisation))
    if args.leave_family_out:
        print(left_out_family_scores(runs))
    return 0


def left_out_family_scores(runs: list) -> str:
    """Per penalty C: the log-loss and the findings at >= 0.9 (right / all) of every finding
    scored by the map fitted on the other families' runs."""
    families = sorted({r["family"] for r in runs})
    lines = ["maps fitted without one family, scoring it", "", "| C | log-loss | right at >= 0.9 |",
             "| --- | --- | --- |"]
    for c in REGULARISATIONS:
        loss, n, high, right = 0.0, 0, 0, 0
        for family in families:
            train = [f for r in runs if r["family"] != family for f in r["findings"] if not f.get("calibrated")]
            calibration = fit_map(train, [f["right"] for f in train], c)
            for f in (f for r in runs if r["family"] == family for f in r["findings"] if not f.get("calibrated")):
                p = min(max(probability(calibration, f), 1e-6), 1.0 - 1e-6)
                loss -= math.log(p if f["right"] else 1.0 - p)
                n += 1
                high += p >= 0.9
                right += p >= 0.9 and f["right"]
        lines.append(f"| {c:g} | {loss / n:.4f} | {right}/{high} |")
    return "\n".join(lines)


def cross_fitted_reliability(runs: list, regularisation: float = REGULARISATION) -> str:
    """Reliability tables with each run's findings scored by the map fitted on the runs of the
    seeds of the other parity."""
    scored = []
    for parity in (0, 1):
        train = [f for r in runs if r["seed"] % 2 != parity for f in r["findings"] if not f.get("calibrated")]
        calibration = fit_map(train, [f["right"] for f in train], regularisation)
        scored += [{**r, "findings": [f if f.get("calibrated") else {**f, "confidence": probability(calibration, f)}
                                      for f in r["findings"]]}
                   for r in runs if r["seed"] % 2 == parity]
    lines = ["cross-fitted (maps fitted on the even / odd seeds, scoring the other half)", "",
             "| confidence | findings | right |", "| --- | --- | --- |"]
    lines += [f"| {r['bin']} | {r['n']} | {r['right']}/{r['n']} |" for r in reliability_rows(scored)]
    lines += ["", "| finding | findings | right | at >= 0.9 | right at >= 0.9 |", "| --- | --- | --- | --- | --- |"]
    lines += [f"| {r['effect']} | {r['n']} | {r['right']}/{r['n']} | {r['n_high']} | {r['right_high']}/{r['n_high']} |"
              for r in reliability_by_effect(scored)]
    high = [f for r in scored for f in r["findings"] if f["confidence"] >= 0.9]
    lines.append(f"\nat >= 0.9: {sum(f['right'] for f in high)}/{len(high)} right")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
