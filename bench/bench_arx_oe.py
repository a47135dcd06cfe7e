"""ARX-OE speed: the C++ per-window estimate against the independent NumPy/SciPy
implementation of the same algorithm (tests/python/identification_reference.py).

Cases (paper Table 1: n = 9, FOPTD, window 2 h = 1,440 samples, step 5 min = 60):
  one window   one 1,440-sample window, estimator built per call (mpmpp.identify.arx_oe)
  all windows  every window of a 10,800-sample SISO record (ArxOeEstimator.estimate_windows)
Data: the paper's SISO plant/noise (G0, H0, sigma = 0.05) in closed loop, from
mpmpp.simulate when it is available, else the saturating-PI stand-in loop.
Run: PYTHONPATH=python python bench/bench_arx_oe.py [--repeat R]
"""
from __future__ import annotations

import argparse
import os
import pathlib
import sys
import time

# Both sides single-threaded (the C++ is): a threaded BLAS only adds overhead on these
# 1,440 x 19 problems and would make the peer look slower than it is.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "python"))
sys.path.insert(0, str(ROOT / "studies"))

import identification_reference as ref  # noqa: E402
from consistency_study import paper_siso_record  # noqa: E402
from mpmpp import identify  # noqa: E402

NA, NB, DELAY, WINDOW, STEP = 9, 10, 17, 1440, 60


def best_time(fn, repeat):
    """Least CPU time of `repeat` runs: process time, not wall time, because the machine
    is shared (wall time would charge either side for other processes' slices)."""
    times = []
    for _ in range(repeat):
        t = time.process_time()
        fn()
        times.append(time.process_time() - t)
    return min(times)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)

    y, u, source = paper_siso_record(10_800, args.seed)
    fir_length = identify.fir_length_to_one_percent(identify._core.TransferFunction(
        [0.1003], [1.0, -0.9048], DELAY))
    yw, uw = y[:WINDOW], u[:WINDOW]

    # Same answer first: a speed ratio between different results would mean nothing.
    cpp = identify.arx_oe(yw, uw, NA, NB, DELAY, fir_length=fir_length)
    theta, _, _, _ = ref.arx_oe(yw, uw[:, None], NA, [NB], [DELAY], [(1, 1, DELAY)], [fir_length])
    assert np.allclose(cpp.oe.theta, theta, rtol=1e-8, atol=1e-8), (cpp.oe.theta, theta)

    # Repeats: the C++ side is ~50x faster, so 40x the runs spans a similar stretch of
    # time (the least CPU time needs runs that miss the other jobs' bursts); the
    # all-windows reference (~1 s a run) gets 3 so that one slow run does not set it.
    t_cpp1 = best_time(lambda: identify.arx_oe(yw, uw, NA, NB, DELAY, fir_length=fir_length),
                       40 * args.repeat)
    t_ref1 = best_time(lambda: ref.arx_oe(yw, uw[:, None], NA, [NB], [DELAY], [(1, 1, DELAY)],
                                          [fir_length]), args.repeat)

    starts = range(0, len(y) - WINDOW + 1, STEP)
    t_cppw = best_time(lambda: identify.arx_oe_windows(y, u, WINDOW, STEP, NA, NB, DELAY,
                                                       fir_length=fir_length), 2 * args.repeat)
    t_refw = best_time(lambda: [ref.arx_oe(y[s:s + WINDOW], u[s:s + WINDOW, None], NA, [NB],
                                           [DELAY], [(1, 1, DELAY)], [fir_length])
                                for s in starts], 3)

    print(f"data: {source}, {len(y)} samples; ARX na={NA} nb={NB} d={DELAY}, OE FOPTD")
    print(f"{'case':<34}{'C++ (ms)':>12}{'NumPy/SciPy (ms)':>19}{'ratio':>9}")
    print(f"{'one 1,440-sample window':<34}{1e3 * t_cpp1:>12.3f}{1e3 * t_ref1:>19.2f}"
          f"{t_ref1 / t_cpp1:>8.0f}x")
    label = f"all {len(starts)} windows (step {STEP})"
    print(f"{label:<34}{1e3 * t_cppw:>12.2f}{1e3 * t_refw:>19.1f}{t_refw / t_cppw:>8.0f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
