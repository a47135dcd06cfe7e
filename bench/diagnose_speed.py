"""Cost of diagnose against record length, and its kernels against named peers.

    python bench/diagnose_speed.py [--lengths 3h,6h,1d,3d,7d]

- diagnose on the paper's 3x3 MD process under MPC at 5 s (scenarios.paper_mimo), records
  from 3 h (the shortest it accepts: three 1 h segments) to 7 days: CPU seconds and peak
  memory of a fresh process per length (the memory before diagnose, imports and data, is
  printed apart), with the CPU per sample relative to the shortest record (1.0 = linear);
- the cross-validated onset scan (`scan_onset_cross_validated`) against the same scan written
  with NumPy suffix sums (peer);
- the same scan of a candidate projected beside disturbance columns inside the pass
  (`ProjectedOnsetScan`) against NumPy projecting it and scanning with suffix sums (peer);
- the gain fitted with a level step at every onset (`ProjectedOnsetScan.fit_with_level_step`)
  against the same two-regressor sums written with NumPy suffix sums (peer, all data);
- the step + ramp trend fit over all onsets (FFT cross-correlations) against one least-squares
  fit per onset with numpy.linalg.lstsq (peer);
- the refitted-noise onset gains of an actuator candidate (`_core.RefittedNoise`) against the
  same sums in NumPy (per-row lag outer products, reduceat, batched solves; peer);
- the C++ k-step predictor against scipy.signal.lfilter doing the same filtering (peer).
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import mpmpp  # noqa: E402
from mpmpp import _core  # noqa: E402
from mpmpp.diagnose import diagnose  # noqa: E402
from mpmpp.diagnose.trend import trend_fit  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "studies"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "python"))
from diagnose_eval import model_of  # noqa: E402
from refitted_noise_reference import numpy_onset_gains  # noqa: E402
from timing import best_of  # noqa: E402
from trend_reference import brute_trend  # noqa: E402

UNITS = {"h": 3600.0, "d": 86400.0}


def seconds(text: str) -> float:
    return float(text[:-1]) * UNITS[text[-1]]


def peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def child(duration_s: float) -> int:
    """One record length in this (fresh) process; prints a JSON line."""
    sc = mpmpp.scenarios.paper_mimo()
    sc["duration_s"] = duration_s
    sc["events"] = [e for e in sc["events"] if e["time_s"] < duration_s]
    data = mpmpp.simulate(sc, seed=1)
    model = model_of(sc)
    base = peak_mb()
    t0 = time.process_time()
    res = diagnose(model, data)
    cpu = time.process_time() - t0
    print(json.dumps({"n": len(data), "cpu_s": cpu, "peak_mb": peak_mb(), "base_mb": base,
                      "findings": [f"{f.effect} {f.output}" for f in res.findings]}))
    return 0


def cost_table(lengths: list[str]) -> None:
    print("diagnose, 3x3 MD process under MPC, 5 s sampling (fresh process per length)")
    print("| record | samples | CPU s | CPU per sample vs shortest | peak MB | of which before diagnose |")
    print("| --- | --- | --- | --- | --- | --- |")
    first = None
    for text in lengths:
        out = subprocess.run([sys.executable, __file__, "--child", str(seconds(text))], capture_output=True,
                             text=True, check=True).stdout.strip().splitlines()[-1]
        r = json.loads(out)
        per_sample = r["cpu_s"] / r["n"]
        first = first or per_sample
        print(f"| {text} | {r['n']} | {r['cpu_s']:.2f} | {per_sample / first:.2f} | {r['peak_mb']:.0f} | "
              f"{r['base_mb']:.0f} |", flush=True)


def numpy_cross_validated_scan(r, r_without, psi, weight, folds, min_segment, step):
    """The peer: suffix sums per weighting with NumPy, then the held-out drops."""
    def suffix(w):
        d = np.cumsum((w * (r**2 - r_without**2))[::-1])[::-1]
        rp = np.cumsum((w * r_without * psi)[::-1])[::-1]
        pp = np.cumsum((w * psi**2)[::-1])[::-1]
        return d, rp, pp

    ks = np.r_[0, np.arange(min_segment, len(r) - min_segment + 1, step)]

    def scan(sums):
        d, rp, pp = sums
        theta = np.divide(rp[ks], pp[ks], out=np.zeros(len(ks)), where=pp[ks] > 0)
        stat = d[ks] + theta * rp[ks]
        i = np.argmax(stat)
        return ks[i], theta[i]

    full = scan(suffix(weight))
    sums = [suffix(weight * f) for f in folds]
    heldout = []
    for k in (0, 1):
        on, theta = scan(sums[k])
        d, rp, pp = sums[1 - k]
        heldout.append(d[on] + 2 * theta * rp[on] - theta**2 * pp[on])
    return full, heldout


def numpy_level_step_onset(r, x, level, z, solve, w, ks):
    """The peer of fit_with_level_step on all data: the onset maximising the two-regressor
    statistic, every suffix sum a reversed NumPy cumsum (the step's projection before the
    onset from the totals)."""
    def rcum(a):
        return np.cumsum(a[::-1], axis=0)[::-1]

    psi = x - z @ (solve @ x)
    wz = w[:, None] * z
    sigma = rcum(solve.T * level[:, None])[ks]
    rz = rcum(wz * r[:, None])[ks]
    rq = rcum(w * r * level)[ks] - np.sum(rz * sigma, axis=1) - np.sum(sigma * (rz[0] - rz), axis=1)
    pq = rcum(w * psi * level)[ks] - np.sum(rcum(wz * psi[:, None])[ks] * sigma, axis=1)
    qq = (rcum(w * level**2)[ks] - 2 * np.sum(rcum(wz * level[:, None])[ks] * sigma, axis=1)
          + np.einsum("ki,ij,kj->k", sigma, wz.T @ z, sigma))
    rp, pp = rcum(w * r * psi)[ks], rcum(w * psi**2)[ks]
    det = pp * qq - pq**2
    theta, c = (qq * rp - pq * rq) / det, (pp * rq - pq * rp) / det
    return ks[np.argmax(theta * rp + c * rq)]


def kernel_ratios(n: int) -> None:
    rng = np.random.default_rng(0)
    r, rw, psi = rng.standard_normal((3, n))
    w = np.ones(n)
    parity = (np.arange(n) // 720) % 2
    folds = [w * (parity == 0), w * (parity == 1)]
    t_cpp = best_of(lambda: _core.scan_onset_cross_validated(r, rw, psi, w, folds[1], 720, 12), 20, time.process_time)[0]
    t_np = best_of(lambda: numpy_cross_validated_scan(r, rw, psi, w, folds, 720, 12), 20, time.process_time)[0]
    cv = _core.scan_onset_cross_validated(r, rw, psi, w, folds[1], 720, 12)
    assert numpy_cross_validated_scan(r, rw, psi, w, folds, 720, 12)[0][0] == cv.full.onset
    print(f"cross-validated onset scan, {n} samples: C++ {1e3 * t_cpp:.2f} ms, NumPy suffix sums "
          f"{1e3 * t_np:.2f} ms -> C++ is {t_np / t_cpp:.1f}x faster")

    # a candidate beside the level and one step + ramp disturbance: projected inside the C++
    # pass against NumPy projecting it and scanning with suffix sums
    t = np.arange(n, dtype=float)
    z = np.column_stack([np.ones(n), t >= n // 3, np.maximum(t - n // 3, 0.0) / 720]) + 0.1 * rng.standard_normal((n, 3))
    solve = np.linalg.pinv((z * w[:, None]).T @ z) @ (z * w[:, None]).T
    rz = r - z @ (solve @ r)
    scan = _core.ProjectedOnsetScan(rz, w, folds[1], z, solve, 0, 720, 12)
    t_proj = best_of(lambda: scan.fit(psi), 20, time.process_time)[0]

    def numpy_projected():
        p = psi - z @ (solve @ psi)
        return numpy_cross_validated_scan(rz, rz, p, w, folds, 720, 12)

    t_np_proj = best_of(numpy_projected, 20, time.process_time)[0]
    assert numpy_projected()[0][0] == scan.fit(psi).full.onset
    print(f"projected onset scan (candidate beside 3 disturbance columns), {n} samples: C++ {1e3 * t_proj:.2f} ms, "
          f"NumPy projection + suffix sums {1e3 * t_np_proj:.2f} ms -> C++ is {t_np_proj / t_proj:.1f}x faster")

    level = 1.0 + 0.05 * rng.standard_normal(n)
    ks = np.r_[0, np.arange(720, n - 720 + 1, 12)]
    t_step = best_of(lambda: scan.fit_with_level_step(psi, level), 20, time.process_time)[0]
    t_np_step = best_of(lambda: numpy_level_step_onset(rz, psi, level, z, solve, w, ks), 5, time.process_time)[0]
    assert numpy_level_step_onset(rz, psi, level, z, solve, w, ks) == scan.fit_with_level_step(psi, level)[0].full.onset
    print(f"gain with a level step at every onset (beside 3 disturbance columns, both folds and the step alone), "
          f"{n} samples: C++ {1e3 * t_step:.2f} ms, NumPy suffix sums (all data only) {1e3 * t_np_step:.2f} ms "
          f"-> C++ is {t_np_step / t_step:.1f}x faster")

    e = rng.standard_normal(n) + 1e-4 * np.maximum(np.arange(n) - n // 2, 0)
    ok = np.ones(n, bool)
    hinv = mpmpp.TransferFunction([1.0, 0.5], [1.0, -0.3])
    t_fft = best_of(lambda: trend_fit(e, ok, hinv, 0, 120, 120), 3, time.process_time)[0]
    t_ls = best_of(lambda: brute_trend(e, ok, hinv, 0, 120, 120), 1, time.process_time)[0]
    assert brute_trend(e, ok, hinv, 0, 120, 120)[0] == trend_fit(e, ok, hinv, 0, 120, 120).onset
    print(f"trend fit over {len(range(120, n - 240, 120))} onsets, {n} samples: FFT {1e3 * t_fft:.1f} ms, "
          f"least squares per onset {1e3 * t_ls:.0f} ms -> {t_ls / t_fft:.0f}x faster")

    onsets = np.r_[0, np.arange(720, n - 720 + 1, 12)]
    kernel = _core.RefittedNoise(e, folds[0], folds[1], onsets.tolist(), 5)
    t_rn = best_of(lambda: kernel.gains(psi), 20, time.process_time)[0]
    t_rn_np = best_of(lambda: numpy_onset_gains(e, psi, folds, onsets, 5), 5, time.process_time)[0]
    assert np.allclose(numpy_onset_gains(e, psi, folds, onsets, 5)[1], kernel.gains(psi).held_out, rtol=1e-6, atol=1e-6)
    print(f"refitted-noise onset gains over {len(onsets)} onsets, {n} samples: C++ {1e3 * t_rn:.2f} ms, "
          f"NumPy {1e3 * t_rn_np:.1f} ms -> C++ is {t_rn_np / t_rn:.0f}x faster")

    g = mpmpp.TransferFunction([0.0763], [1.0, -0.0723], 15)
    h = mpmpp.TransferFunction([1.0, -0.5], [1.0, 0.5])
    u, y = rng.standard_normal((n, 1)), rng.standard_normal(n)
    t_pred = best_of(lambda: _core.predict_output([g], h, y, u, 10), 20, time.process_time)[0]

    def scipy_pred():
        v = y - lfilter(np.r_[np.zeros(15), 0.0763], [1.0, -0.0723], u[:, 0])
        e = lfilter([1.0, 0.5], [1.0, -0.5], v)
        hk = lfilter([1.0, -0.5], [1.0, 0.5], np.r_[1.0, np.zeros(9)])
        return y - lfilter(hk, [1.0], e)

    t_sp = best_of(scipy_pred, 20, time.process_time)[0]
    print(f"10-step prediction, {n} samples: C++ {1e3 * t_pred:.2f} ms, scipy lfilter {1e3 * t_sp:.2f} ms "
          f"-> ratio C++/scipy {t_pred / t_sp:.2f}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--lengths", default="3h,6h,1d,3d,7d")
    p.add_argument("--child", type=float, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child is not None:
        return child(args.child)
    cost_table(args.lengths.split(","))
    print()
    kernel_ratios(17280)
    return 0


if __name__ == "__main__":
    sys.exit(main())
