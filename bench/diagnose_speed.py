"""Speed of compare / diagnose, printed as ratios against named peers in the same run.

    python bench/diagnose_speed.py

- diagnose on a 3x3, 20 h closed-loop data set (the paper's MIMO MD process under MPC,
  14400 samples) against the issue's 10 s budget;
- the C++ onset scan (`scan_onset`) against the same scan written with NumPy suffix sums
  (peer), per candidate shape;
- the C++ k-step predictor against scipy.signal.lfilter doing the same filtering (peer).
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from scipy.signal import lfilter

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import mpmpp  # noqa: E402
from mpmpp import _core  # noqa: E402
from mpmpp.compare import compare  # noqa: E402
from mpmpp.diagnose import diagnose  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from diagnose_eval import model_of  # noqa: E402


def best_of(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def numpy_scan(r, r_without, psi, weight, min_segment, step):
    d = np.cumsum((weight * (r**2 - r_without**2))[::-1])[::-1]
    rp = np.cumsum((weight * r_without * psi)[::-1])[::-1]
    pp = np.cumsum((weight * psi**2)[::-1])[::-1]
    ks = np.r_[0, np.arange(min_segment, len(r) - min_segment + 1, step)]
    stat = d[ks] + rp[ks] ** 2 / pp[ks]
    k = ks[np.argmax(stat)]
    return k, stat.max()


def main() -> int:
    sc = mpmpp.scenarios.paper_mimo()
    sc["duration_s"] = 20 * 3600.0
    sc["events"] = [e for e in sc["events"] if e["time_s"] < sc["duration_s"]]
    t0 = time.perf_counter()
    data = mpmpp.simulate(sc, seed=1)
    t_sim = time.perf_counter() - t0
    model = model_of(sc)
    t_diag = best_of(lambda: diagnose(model, data), repeat=2)
    for f in diagnose(model, data).findings:
        print(f"  finding {f.id}: {f.effect} {f.output} <- {f.input} at {f.onset_s / 60:.0f} min")
    t_cmp = best_of(lambda: compare(model, data), repeat=2)
    print(f"3x3, 20 h, {len(data)} samples (simulated in {t_sim:.1f} s)")
    print(f"  diagnose: {t_diag:.2f} s = {t_diag / 10.0:.2f} x the 10 s budget")
    print(f"  compare:  {t_cmp:.2f} s")

    rng = np.random.default_rng(0)
    n = len(data)
    r, rw, psi = rng.standard_normal(n), rng.standard_normal(n), rng.standard_normal(n)
    w = np.ones(n)
    t_cpp = best_of(lambda: _core.scan_onset(r, rw, psi, w, 720, 12), repeat=20)
    t_np = best_of(lambda: numpy_scan(r, rw, psi, w, 720, 12), repeat=20)
    f = _core.scan_onset(r, rw, psi, w, 720, 12)
    assert numpy_scan(r, rw, psi, w, 720, 12)[0] == f.onset
    print(f"  onset scan, {n} samples: C++ {1e3 * t_cpp:.2f} ms, NumPy suffix sums {1e3 * t_np:.2f} ms "
          f"-> C++ is {t_np / t_cpp:.1f}x faster")

    g = mpmpp.TransferFunction([0.0763], [1.0, -0.0723], 15)
    h = mpmpp.TransferFunction([1.0, -0.5], [1.0, 0.5])
    u, y = rng.standard_normal((n, 1)), rng.standard_normal(n)
    t_pred = best_of(lambda: _core.predict_output([g], h, y, u, 10), repeat=20)

    def scipy_pred():
        v = y - lfilter(np.r_[np.zeros(15), 0.0763], [1.0, -0.0723], u[:, 0])
        e = lfilter([1.0, 0.5], [1.0, -0.5], v)
        hk = lfilter([1.0, -0.5], [1.0, 0.5], np.r_[1.0, np.zeros(9)])
        return y - lfilter(hk, [1.0], e)

    t_sp = best_of(scipy_pred, repeat=20)
    print(f"  10-step prediction, {n} samples: C++ {1e3 * t_pred:.2f} ms, scipy lfilter {1e3 * t_sp:.2f} ms "
          f"-> ratio C++/scipy {t_pred / t_sp:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
