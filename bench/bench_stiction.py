"""Stiction analysis speed: mpmpp's C++ actuator model against the plain Python reference of the
same equations (tests/python/valve_reference.py), the whole Hammerstein fit of one
751-sample record against the baselines, and on a week of a 10 s loop the fit's held-out
errors of every ARX structure from the folds' Gram matrices against one numpy.linalg.lstsq per
fold and structure (peer).

    python bench/bench_stiction.py [--repeat N]
"""
import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "python"), str(ROOT / "tests" / "python")]

# the imports below need the paths above
from mpmpp._core import ActuatorNonlinearity, actuator_positions  # noqa: E402
from mpmpp.periodic_disturbance import dominant_frequency  # noqa: E402
from mpmpp.stiction import BASELINES, fit_valve, hammerstein  # noqa: E402
from mpmpp.stiction.loop import Process, coloured_noise, simulate_pi_loop  # noqa: E402
from valve_reference import choudhury_reference, per_fold_lstsq_losses  # noqa: E402
from timing import best_of  # noqa: E402



def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    op = np.cumsum(rng.standard_normal(751))
    sticky = ActuatorNonlinearity(stiction_s=3.0, stiction_j=1.0)
    t_cpp = best_of(lambda: actuator_positions(op, sticky, op[0]), args.repeat)[0]
    t_py = best_of(lambda: choudhury_reference(op, 3.0, 1.0), args.repeat)[0]
    print(f"stick-slip valve, 751 samples: C++ {t_cpp * 1e6:.0f} us, Python reference "
          f"{t_py * 1e6:.0f} us, ratio {t_py / t_cpp:.0f}x")
    p = np.exp(-10 / 15)
    rec = simulate_pi_loop(Process(b=(1 - p,), a=(1.0, -p)), 0.7, 1.5, 751,
                           valve=ActuatorNonlinearity(stiction_s=4.0, stiction_j=2.0),
                           disturbance=coloured_noise(rng, 751, 0.3, 0.8))
    t_fit = best_of(lambda: fit_valve(rec["op"], rec["pv"]), args.repeat)[0]
    print(f"Hammerstein fit of one 751-sample record: {t_fit * 1e3:.0f} ms")
    for name, test in BASELINES.items():
        t = best_of(lambda test=test: test(rec["op"], rec["pv"], rec["sp"]), args.repeat)[0]
        print(f"  {name}: {t * 1e3:.1f} ms (Hammerstein fit / {name} time: {t_fit / t:.1f})")
    n = 7 * 8640
    week = simulate_pi_loop(Process(b=(1 - p,), a=(1.0, -p), delay=4), 0.25, 3.0, n,
                            disturbance=coloured_noise(rng, n, 0.3, 0.8))
    t_week = best_of(lambda: fit_valve(week["op"], week["pv"], first_lag=5), 1)[0]
    print(f"Hammerstein fit of a week at 10 s ({n} samples, with the dead-time window): {t_week:.2f} s")
    window = hammerstein.dead_time_window(5)
    y = (week["pv"] - week["pv"].mean()) / week["pv"].std()
    f = dominant_frequency(y)
    phi, target = hammerstein._lagged(y, week["op"], f, hammerstein.N_U, 0, window, 12, hammerstein.LONG_N_Y)
    structures = [hammerstein._structure_columns(n_y, k, w, periodic, window)
                  for n_y in (hammerstein.N_Y, hammerstein.LONG_N_Y) for k in range(hammerstein.N_U + 1)
                  for w in ((), window) for periodic in (False, True)]

    def from_grams():   # as the fit does: one design's Gram matrices, every structure from them
        grams = hammerstein.FoldGrams(phi, target)
        return [grams.held_out_sse(c) for c in structures]

    t_grams = best_of(from_grams, 1)[0]
    t_lstsq = best_of(lambda: [per_fold_lstsq_losses(phi[:, c], target, hammerstein.N_FOLDS).sum()
                               for c in structures], 1)[0]
    print(f"  the linear valve's {len(structures)} structures: fold Gram matrices {t_grams * 1e3:.0f} ms, "
          f"lstsq per fold and structure {t_lstsq * 1e3:.0f} ms, ratio {t_lstsq / t_grams:.0f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
