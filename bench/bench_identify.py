"""Speed of ``mpmpp identify`` (model_from_data).

Cases:
  search, threads   the whole search (every process class, noise order, dead time and numerator
                    length) on one thread against ``--workers`` threads, wall time: the sweeps
                    per noise order are independent and their ARX-OE fits release the GIL
  classes           the whole search over first order plus dead time only, against every class
                    (first order; integrating, with a lag, with the disturbance at the output),
                    one thread: what recognising integrating processes costs
  one candidate     one structure's joint prediction-error fit (ARX-OE start, then the
                    alternating refinement) against SciPy's least_squares on the same criterion
                    from its own ARX-OE (tests/python/identification_reference.pem_ar_noise),
                    CPU time
  refit range       diagnose's reference refit (diagnose/reference_refit.py) of a 1 s PI flow loop
                    (10,000 rows) under a hand-written model (gain 1.3x, time constant 0.7x, dead
                    time 8 s for the plant's 12 s): dead times up to the model channel's settling
                    time against identify's default 600 s (peer), one thread, CPU; the same
                    channel asserted
Records: a 751-row PI pressure loop with setpoint steps (tests/python/pi_loop.py, 2 h at 10 s)
and the example siso_gain_change (5 s, 16 h).
Run: PYTHONPATH=python python bench/bench_identify.py [--repeat R] [--workers W]
"""
from __future__ import annotations

import argparse
import json
import os
import pathlib
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))
sys.path.insert(0, str(ROOT / "bench"))

import identification_reference as ref  # noqa: E402
import pi_loop  # noqa: E402
from timing import best_of  # noqa: E402

import mpmpp  # noqa: E402
import mpmpp.model_identification as mi  # noqa: E402
from mpmpp import structure_search  # noqa: E402
from mpmpp.process_class import SELF_REGULATING  # noqa: E402
from mpmpp.io import load_data  # noqa: E402


def records():
    yield "PI loop, 751 rows", pi_loop.simulate(pi_loop.PRESSURE, 4, setpoint_steps=True), "OP", "PV"
    example = ROOT / "examples" / "siso_gain_change"
    yield "siso_gain_change", load_data(example / "data.csv"), "stock_flow", "dry_weight"


def refit_range(repeat: int) -> None:
    from mpmpp.diagnose.reference_refit import _longest_dead_time_s

    loop = pi_loop.FLOW
    df = pi_loop.simulate(loop, 1, rows=10_000, ts=1.0, setpoint_steps=True)
    model = mpmpp.Model.from_json(json.dumps({
        "name": "flow", "sample_time_s": 1.0, "inputs": ["OP"], "outputs": ["PV"],
        "process": {"PV": {"OP": {"gain": 1.3 * loop.gain, "time_constant_s": 0.7 * loop.time_constant_s,
                                  "dead_time_s": 8.0}}}}), "hand-written flow model")
    longest = _longest_dead_time_s(model, model.process("PV", "OP"), False)

    def refit(max_dead_time_s):
        return mi.model_from_data(df, ["OP"], ["PV"], workers=1, max_dead_time_s=max_dead_time_s,
                                  classes=(SELF_REGULATING,))

    t_ours, ours = best_of(lambda: refit(longest), repeat, clock=time.process_time)
    t_peer, peer = best_of(lambda: refit(mi.DEFAULT_MAX_DEAD_TIME_S), repeat, clock=time.process_time)
    g, h = ours.model.process("PV", "OP"), peer.model.process("PV", "OP")
    assert g.delay == h.delay and np.allclose(g.num, h.num) and np.allclose(g.den, h.den)
    print(f"refit range      PI flow loop at 1 s: dead times to {longest:.0f} s {t_ours:.2f} s, to "
          f"{mi.DEFAULT_MAX_DEAD_TIME_S:.0f} s {t_peer:.2f} s CPU, ratio {t_peer / t_ours:.1f}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args(argv)
    print(f"{os.cpu_count()} cores seen; least of {args.repeat} run(s)")
    for label, df, u, y in records():
        one, r1 = best_of(lambda: mi.model_from_data(df, [u], [y], workers=1), args.repeat)
        many, rw = best_of(lambda: mi.model_from_data(df, [u], [y], workers=args.workers), args.repeat)
        assert r1.to_dict() == rw.to_dict()
        print(f"search, threads  {label} ({len(df)} rows, {r1.outputs[0].candidates} candidates): "
              f"1 thread {one:.2f} s, {args.workers} threads {many:.2f} s, ratio {one / many:.2f}")
        fo, _ = best_of(lambda: mi.model_from_data(df, [u], [y], workers=1, classes=(SELF_REGULATING,)),
                        args.repeat)
        print(f"classes          {label}: first order only {fo:.2f} s, all classes {one:.2f} s, ratio {one / fo:.2f}")
        c = r1.channels[0]
        if c.integrating:
            continue
        yv = df[y].to_numpy(dtype=float)
        uv = df[u].to_numpy(dtype=float)
        yd, ud = yv - yv.mean(), (uv - uv.mean())[:, None]
        na, t0 = r1.outputs[0].noise_order, 1 + max(mi.NA_ORDERS)

        def ours():
            c0 = structure_search.fit_candidate(yd, ud, na, [c.delay_samples], [c.numerator_length], SELF_REGULATING, t0)
            return structure_search.refine(yd, ud, c0, SELF_REGULATING, t0)

        def scipy_peer():
            return ref.pem_ar_noise(yv, uv, na, c.numerator_length, c.delay_samples)

        t_ours, fit = best_of(ours, 3 * args.repeat, clock=time.process_time)
        t_ref, (b, _, _) = best_of(scipy_peer, 3 * args.repeat, clock=time.process_time)
        assert np.allclose(np.asarray(fit.tf[0].num), b, rtol=1e-4, atol=1e-8)
        print(f"one candidate    {label}: mpmpp {t_ours * 1e3:.1f} ms, SciPy {t_ref * 1e3:.1f} ms CPU, "
              f"ratio {t_ref / t_ours:.1f}")
    refit_range(args.repeat)


if __name__ == "__main__":
    main()
