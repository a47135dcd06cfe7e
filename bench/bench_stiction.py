"""Stiction analysis speed: mpmpp's C++ valve models against the plain Python reference of the
same equations (tests/python/valve_reference.py), and the whole Hammerstein fit of one
751-sample record against the baselines.

    python bench/bench_stiction.py [--repeat N]
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "python"), str(ROOT / "tests" / "python")]

from mpmpp._core import Valve, ValveKind
from mpmpp.stiction import BASELINES, fit_valve
from mpmpp.stiction.loop import Process, coloured_noise, simulate_pi_loop
from valve_reference import choudhury_reference


def best_of(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    op = np.cumsum(rng.standard_normal(751))
    t_cpp = best_of(lambda: Valve(ValveKind.stick_slip, 3.0, 1.0).apply(op), args.repeat)
    t_py = best_of(lambda: choudhury_reference(op, 3.0, 1.0), args.repeat)
    print(f"stick-slip valve, 751 samples: C++ {t_cpp * 1e6:.0f} us, Python reference "
          f"{t_py * 1e6:.0f} us, ratio {t_py / t_cpp:.0f}x")
    p = np.exp(-10 / 15)
    rec = simulate_pi_loop(Process(b=(1 - p,), a=(1.0, -p)), 0.7, 1.5, 751,
                           valve=Valve(ValveKind.stick_slip, 4.0, 2.0),
                           disturbance=coloured_noise(rng, 751, 0.3, 0.8))
    t_fit = best_of(lambda: fit_valve(rec["op"], rec["pv"]), args.repeat)
    print(f"Hammerstein fit of one 751-sample record: {t_fit * 1e3:.0f} ms")
    for name, test in BASELINES.items():
        t = best_of(lambda test=test: test(rec["op"], rec["pv"], rec["sp"]), args.repeat)
        print(f"  {name}: {t * 1e3:.1f} ms (Hammerstein fit / {name} time: {t_fit / t:.1f})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
