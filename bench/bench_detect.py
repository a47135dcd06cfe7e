"""Whole paper demos (simulate + train + monitor) against a plain NumPy/SciPy + scikit-learn
implementation of the same detector (bench/reference_detect.py) on the same simulated data.

    python bench/bench_detect.py [--seeds N]

Targets: SISO demo < 1 s of compute, MIMO < 3 s. Prints medians over the seeds.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
import mpmpp  # noqa: E402
from mpmpp.detect import _arrays, detect, make_config  # noqa: E402
from mpmpp.evaluate import load_scenario, nominal_model  # noqa: E402
from reference_detect import ChannelSvm, indicator, window_features  # noqa: E402


def reference_pipeline(model, data, config):
    """The same steps in NumPy/SciPy/scikit-learn: windows, ARX + A-filter + FOPTD OE, FIR,
    resampling, standardisation, OneClassSVM with a fixed outlier fraction, indicator."""
    time_s, u, y = _arrays(model, data)
    W, S = config.window_samples(model.sample_time_s), config.step_samples(model.sample_time_s)
    channels, delays, fir_len = {}, {}, {}
    for i, out in enumerate(model.outputs):
        for j, inp in enumerate(model.inputs):
            g = model.process(out, inp)
            if g is not None:
                channels.setdefault(i, []).append(j)
                delays[(i, j)] = g.delay
                imp = np.abs(np.asarray(g.impulse(g.delay + 5000)))[g.delay:]
                fir_len[(i, j)] = int(np.nonzero(imp >= 0.01 * imp.max())[0].max() + 1)
    starts = range(0, len(y) - W + 1, S)
    feats = [window_features(y[s:s + W], u[s:s + W], channels, delays, config.arx_order_a,
                             config.arx_order_b, fir_len) for s in starts]
    ends = np.array([s + W for s in starts]) * model.sample_time_s
    train = ends <= config.train_duration_s
    rng = np.random.default_rng(0)
    alarms = {}
    for key in feats[0]:
        svm = ChannelSvm([f[key] for f, t in zip(feats, train) if t], config.alpha, config.nu, config.kernel_scale,
                         0.05, config.resampled_models, rng)
        scores = np.array([0.0 if t else svm.score(f[key]) for f, t in zip(feats, train)])
        alarms[key] = ends[indicator(scores, config.inspection_windows()) >= config.threshold]
    return alarms


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    args = ap.parse_args()
    print(f"{'demo':<6} {'simulate s':>10} {'mpmpp detect s':>14} {'total s':>8} {'target':>7} "
          f"{'peer detect s':>13} {'peer / mpmpp':>12}")
    for name, target in (("siso", 1.0), ("mimo", 3.0)):
        scenario = load_scenario(f"paper_{name}")
        model = nominal_model(scenario)
        config = make_config(name)  # the recommended preset, as the demo uses
        sim, det, peer = [], [], []
        for seed in range(args.seeds):
            t0 = time.process_time()
            data = mpmpp.simulate(scenario, seed=seed)
            t1 = time.process_time()
            detect(model, data, None, config)
            t2 = time.process_time()
            sim.append(t1 - t0)
            det.append(t2 - t1)
            if seed == 0:  # the peer is slow: one run
                t3 = time.process_time()
                reference_pipeline(model, data, config)
                peer.append(time.process_time() - t3)
        s, d, p = np.median(sim), np.median(det), np.median(peer)
        print(f"{name:<6} {s:>10.3f} {d:>14.3f} {s + d:>8.3f} {'<' + format(target, 'g') + ' s':>7} "
              f"{p:>13.3f} {p / d:>11.1f}x")
    print("times are process CPU seconds (time.process_time), medians over seeds; peer: "
          "bench/reference_detect.py (NumPy ARX + SciPy least_squares OE + scikit-learn OneClassSVM, "
          "outlier fraction fixed at 0.05 instead of cross-validated)")


if __name__ == "__main__":
    main()
