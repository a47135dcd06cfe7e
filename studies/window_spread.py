"""Why detection fails on scenario families: how far the window estimates spread against their
own estimator covariance, and how far a change moves them (docs/families.md).

    python studies/window_spread.py [--families A,B] [--seeds N] [--first-seed S]
                                    [--config CONFIG] [--workers K]

Per run and process channel, with d^2 = (x - mean)' C^-1 (x - mean) / dim, x a window's FIR
estimate, C its two-step covariance and mean the training windows' mean:

* k: the measured spread ratio, the training windows' average d^2 over (1 - r), r the training
  mean's variance ratio (``mean_variance_ratio``: a window's deviation from a mean it is part of
  has covariance (1 - r) C on average). k = 1 when the estimator covariance is right;
* normal / after: the median d^2 of monitored windows before the change and of windows that
  end 2 h or more after it. A change the features can show has after >> normal.

CONFIG must use ``"resampling": "estimator"`` (the window covariances); default: the ``siso`` or
``mimo`` preset with the FIR OE structure and estimator resampling.
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from mpmpp import _core
from mpmpp import families as fam
from mpmpp.detect import Detector
from mpmpp.evaluate import nominal_model
from mpmpp.parallel import run_tasks
from mpmpp.simulate import simulate

HOUR = 3600.0


def default_config(size: int) -> dict:
    if size > 1:
        return {"preset": "mimo"}
    return {"preset": "siso", "oe_structure": "fir", "resampling": "estimator", "outlier_fraction": 0.05}


def _median(values: np.ndarray):
    return float(np.nanmedian(values)) if np.isfinite(values).any() else None


def window_spread(name: str, seed: int, config: dict | None) -> dict:
    family = fam.family(name)
    spec, expect = family.draw(seed)
    model = nominal_model(spec)
    data = simulate(spec)
    config = config or default_config(family.size)
    detector, series = Detector._train(model, data, None, config)
    features = _core.WindowFeatures(model, detector.config)
    t0 = float(data["time"].iloc[0])
    ends = np.array([w["end_s"] for w in series.windows]) - t0
    firsts = np.array([w["first"] for w in series.windows])
    train = ends <= detector.train_end_s
    onset = expect["onset_s"] if expect["kind"] != "none" and expect["onset_s"] is not None else np.inf
    channels = []
    for k, (kind, _, _) in enumerate(features.channels):
        if kind != "process":
            continue
        x = np.asarray(series.features[k])
        dim = x.shape[1]
        cov = np.asarray(series.covariances[k]).reshape(len(x), dim, dim)
        ok = np.isfinite(x).all(axis=1)
        rows = np.flatnonzero(train & ok)
        mean = x[rows].mean(axis=0)
        d2 = np.full(len(x), np.nan)
        for i in np.flatnonzero(ok):
            d2[i] = (x[i] - mean) @ np.linalg.solve(cov[i], x[i] - mean) / dim
        r = _core.mean_variance_ratio(firsts[rows].tolist(), features.window_samples)
        channels.append({"dim": dim, "k": float(np.mean(d2[rows]) / (1 - r)),
                         "normal": _median(d2[~train & (ends < onset)]), "after": _median(d2[ends >= onset + 2 * HOUR])})
    return {"family": name, "seed": seed, "effect": expect["effect"], "channels": channels}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--families", default="mpc_siso,mpc_siso_controls,pi_siso", help="comma-separated family names")
    p.add_argument("--seeds", type=int, default=10)
    p.add_argument("--first-seed", type=int, default=0)
    p.add_argument("--config", help="detector config JSON with estimator resampling (default: see above)")
    p.add_argument("--workers", type=int)
    args = p.parse_args(argv)
    try:
        config = None if args.config is None else json.loads(args.config)
        names = [n.strip() for n in args.families.split(",")]
        for n in names:
            fam.family(n)
    except ValueError as exc:
        print(f"window_spread: error: {exc}", file=sys.stderr)
        return 2
    runs, where = run_tasks(window_spread, [(n, s, config) for n in names
                                             for s in range(args.first_seed, args.first_seed + args.seeds)],
                            workers=args.workers)
    runs.sort(key=lambda r: (names.index(r["family"]), r["seed"]))
    print(f"window spread against the estimator covariance ({where})\n")
    print("| family | seed | effect | dim | k | normal d^2 | after d^2 |\n| --- | --- | --- | --- | --- | --- | --- |")
    fmt = lambda v: "-" if v is None else f"{v:.2f}"  # noqa: E731
    for r in runs:
        for c in r["channels"]:
            print(f"| {r['family']} | {r['seed']} | {r['effect']} | {c['dim']} | {c['k']:.2f} | "
                  f"{fmt(c['normal'])} | {fmt(c['after'])} |")
    for n in names:
        ks = [c["k"] for r in runs if r["family"] == n for c in r["channels"]]
        ratio = [c["after"] / c["normal"] for r in runs if r["family"] == n for c in r["channels"]
                 if c["after"] is not None and c["normal"]]
        print(f"\n{n}: k median {np.median(ks):.1f} (range {min(ks):.1f}-{max(ks):.1f})"
              + (f"; after / normal median {np.median(ratio):.2f}, above 2 in {sum(x > 2 for x in ratio)}/{len(ratio)}"
                 if ratio else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
