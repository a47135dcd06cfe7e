"""``mpmpp simulate SCENARIO.json -o DATA.csv [--seed N] [--plot FIG.png] [--record-qps QPS.npz]``,
``mpmpp simulate --paper siso|mimo ...`` and ``mpmpp simulate --family NAME --seed N ...``: a
closed-loop run of a scenario (docs/scenario.md; families: docs/families.md) written as a data
file (docs/formats.md)."""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", metavar="SCENARIO", nargs="?", help="scenario file (JSON, docs/scenario.md)")
    parser.add_argument("--paper", choices=["siso", "mimo"], help="the paper's example instead of a file")
    parser.add_argument("--family", metavar="NAME",
                        help="a draw of a scenario family instead of a file (docs/families.md); --seed picks it")
    parser.add_argument("-o", "--output", metavar="DATA.csv", help="data file to write (CSV, docs/formats.md)")
    parser.add_argument("--seed", type=int, help="noise seed (default: the scenario's)")
    parser.add_argument("--plot", metavar="FIG.png", help="also plot CV/MV profiles (like the paper's Figs 3, 5, 6)")
    parser.add_argument("--record-qps", metavar="QPS.npz",
                        help="save every MPC QP (P, A fixed; q, l, u per sample) for QP tests and benches")
    parser.add_argument("--write-scenario", metavar="SCENARIO.json", help="write the scenario file used")
    parser.add_argument("--write-model", metavar="MODEL.json",
                        help="write the scenario's model file (the controller's model, in the form the scenario gives it)")
    parser.add_argument("--json", action="store_true", help="print one JSON summary instead of text")


def run(args: argparse.Namespace) -> int:
    from ..io import atomic_output, save_data
    from ..plots import plot_simulation
    from ..scenario import MODEL_KEYS, load_scenario, parse_scenario
    from ..simulate import frame
    from .. import _core, scenarios

    if sum(x is not None for x in (args.scenario, args.paper, args.family)) != 1:
        raise ValueError("give one of SCENARIO, --paper siso|mimo or --family NAME")
    if not (args.output or args.plot or args.record_qps or args.write_scenario or args.write_model):
        raise ValueError("nothing to write: give -o DATA.csv, --plot, --record-qps, --write-scenario or --write-model")
    if args.family:
        from ..families import family

        # The seed draws the whole scenario (plant, controller, events), not only the noise.
        sc = parse_scenario(family(args.family).scenario(0 if args.seed is None else args.seed))
        args.seed = None
    elif args.paper:
        spec = scenarios.paper_siso() if args.paper == "siso" else scenarios.paper_mimo()
        sc = parse_scenario(spec)
    else:
        sc = load_scenario(args.scenario)
    if args.write_scenario:
        with atomic_output(args.write_scenario) as f:
            json.dump(sc.spec, f, indent=2)
    if args.write_model:
        with atomic_output(args.write_model) as f:
            json.dump({k: sc.spec[k] for k in MODEL_KEYS if k in sc.spec}, f, indent=2)
    res = _core.simulate_closed_loop(sc.to_config(args.seed, record_qps=bool(args.record_qps)))
    df = frame(sc, res)
    written = []
    if args.output:
        save_data(args.output, df)
        written.append(args.output)
    if args.plot:
        written += [str(p) for p in plot_simulation(df, sc.inputs, sc.outputs, args.plot,
                                                    df.attrs["event_times_s"], sc.name)]
    if args.record_qps:
        # Through a file object numpy adds no ".npz"; add it as numpy would for a path.
        if not args.record_qps.endswith(".npz"):
            args.record_qps += ".npz"
        with atomic_output(args.record_qps, "wb") as f:
            np.savez_compressed(f, P=res.qp_P, A=res.qp_A, q=res.qp_q, l=res.qp_l, u=res.qp_u)
        written.append(args.record_qps)
    summary = {"scenario": sc.name, "samples": sc.num_samples, "sample_time_s": sc.sample_time_s,
               "seed": sc.seed if args.seed is None else args.seed, "events": len(sc.events),
               "failed_solves": int(res.failed_solves), "written": written}
    if args.json:
        json.dump(summary, sys.stdout)
        print()
    else:
        print(f"{sc.name}: {sc.num_samples} samples at {sc.sample_time_s:g} s, {len(sc.events)} events, "
              f"seed {summary['seed']}")
        for path in written:
            print(f"  wrote {path}")
        if res.failed_solves:
            print(f"  warning: {res.failed_solves} MPC solves did not converge (best iterate applied)")
    return 0
