"""Fit and decision_function time of mpmpp.OneClassSVM against sklearn.svm.OneClassSVM (libsvm).

    python bench/bench_one_class_svm.py [--quick] [--repeats 3] [--threads 1]

Both solvers get the same data, nu, gamma = 1 / kernel_scale (kernel_scale = d, so the kernel
is neither flat nor spiky), tol = 1e-3 and a 200 MB kernel cache. Times are the median of
`--repeats` runs, measured as process CPU time (robust on a shared, oversubscribed machine; both
sides are single-threaded unless --threads > 1, which only affects mpmpp's decision_function)
and as wall-clock time. Ratios are scikit-learn / mpmpp: > 1 means mpmpp is faster. The decision
function is evaluated on the training points. --quick drops n = 20,000.
"""
import argparse
import statistics
import time

import numpy as np
from sklearn.svm import OneClassSVM as SkOneClassSVM

import mpmpp


def timed(fn):
    c0, w0 = time.process_time(), time.perf_counter()
    out = fn()
    return out, time.process_time() - c0, time.perf_counter() - w0


def median_times(fn, repeats):
    cpu, wall, out = [], [], None
    for _ in range(repeats):
        out, c, w = timed(fn)
        cpu.append(c)
        wall.append(w)
    return out, statistics.median(cpu), statistics.median(wall)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="skip n = 20,000")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1, help="mpmpp decision_function threads")
    args = ap.parse_args()
    sizes = (1000, 5000) if args.quick else (1000, 5000, 20000)
    print(f"{'n':>6} {'d':>4} {'nu':>5} | {'fit sk':>8} {'fit mp':>8} {'ratio':>6} | "
          f"{'dec sk':>8} {'dec mp':>8} {'ratio':>6} | {'wall fit':>8} {'wall dec':>8} | max|diff|/scale")
    fit_ratios, dec_ratios = [], []
    for n in sizes:
        for d in (30, 100):
            for nu in (0.5, 0.05):
                X = np.random.default_rng(n + d).standard_normal((n, d))
                sk = SkOneClassSVM(nu=nu, gamma=1.0 / d, tol=1e-3, cache_size=200)
                mp = mpmpp.OneClassSVM(nu=nu, kernel_scale=float(d), tol=1e-3, cache_mb=200,
                                       n_threads=args.threads)
                _, fit_sk, wfit_sk = median_times(lambda: sk.fit(X), args.repeats)
                _, fit_mp, wfit_mp = median_times(lambda: mp.fit(X), args.repeats)
                dsk, dec_sk, wdec_sk = median_times(lambda: sk.decision_function(X), args.repeats)
                dmp, dec_mp, wdec_mp = median_times(lambda: mp.decision_function(X), args.repeats)
                scale = np.max(np.abs(sk.score_samples(X)))
                fit_ratios.append(fit_sk / fit_mp)
                dec_ratios.append(dec_sk / dec_mp)
                print(f"{n:>6} {d:>4} {nu:>5} | {fit_sk:8.3f} {fit_mp:8.3f} {fit_ratios[-1]:6.2f} | "
                      f"{dec_sk:8.3f} {dec_mp:8.3f} {dec_ratios[-1]:6.2f} | "
                      f"{wfit_sk / wfit_mp:8.2f} {wdec_sk / wdec_mp:8.2f} | "
                      f"{np.max(np.abs(dsk - dmp)) / scale:.1e}", flush=True)
    def geo(r):
        return float(np.exp(np.mean(np.log(r))))
    print(f"fit speed-up (CPU time): min {min(fit_ratios):.2f}, geometric mean {geo(fit_ratios):.2f}"
          f"  (target >= 2)")
    print(f"decision_function speed-up (CPU time): min {min(dec_ratios):.2f}, geometric mean "
          f"{geo(dec_ratios):.2f}  (target >= 5)")


if __name__ == "__main__":
    main()
