"""Streaming detector (C++) against the batch Python path on the same data.

    python bench/bench_streaming.py [--repeats N]

For each paper scenario (seed 0): train once (Python), then time on the whole data set
  * batch:   mpmpp.Detector.monitor (Python orchestration over the C++ core: all windows at once);
  * stream:  StreamingDetector.push_block (C++ loop: ring buffer, window ARX-OE + SVMs);
  * per-sample buffering cost: pushing samples that complete no window;
  * stream from Python: one StreamingDetector.push call per sample (includes Python call overhead).
Process CPU seconds (time.process_time), best of --repeats.
"""
from __future__ import annotations

import argparse
import time


import mpmpp
from mpmpp.detect import make_config
from mpmpp.evaluate import load_scenario, nominal_model


def best(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return min(times)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    print(f"{'demo':<5} {'samples':>7} {'windows':>7} {'batch s':>8} {'stream s':>8} {'batch/stream':>12} "
          f"{'per window ms':>13} {'per sample us':>13} {'py push s':>9}")
    for name in ("siso", "mimo"):
        scenario = load_scenario(f"paper_{name}")
        model = nominal_model(scenario)
        data = mpmpp.simulate(scenario, seed=0)
        detector = mpmpp.Detector.train(model, data, None, make_config(f"paper_{name}"))
        t = data["time"].to_numpy()
        u, y = data[list(model.inputs)].to_numpy(), data[list(model.outputs)].to_numpy()
        n_windows = len(detector.monitor(data).windows)

        batch = best(lambda: detector.monitor(data), args.repeats)
        stream = best(lambda: mpmpp.StreamingDetector(detector).push_block(t, u, y), args.repeats)
        # Buffering only: W - 1 samples complete no window; the stream is reset between
        # repeats by restoring its empty checkpoint (timed alone and subtracted).
        s = mpmpp.StreamingDetector(detector)
        empty, w, reps = s.checkpoint_json(), s.window_samples, 50

        def fill():
            for _ in range(reps):
                s.restore_checkpoint_json(empty)
                s.push_block(t[:w - 1], u[:w - 1], y[:w - 1])

        def reset():
            for _ in range(reps):
                s.restore_checkpoint_json(empty)
        per_sample_us = max(best(fill, args.repeats) - best(reset, args.repeats), 0.0) / (reps * (w - 1)) * 1e6

        def python_loop():
            s = mpmpp.StreamingDetector(detector)
            for k in range(len(t)):
                s.push(t[k], u[k], y[k])
        py_push = best(python_loop, 1)
        print(f"{name:<5} {len(t):>7} {n_windows:>7} {batch:>8.3f} {stream:>8.3f} {batch / stream:>11.2f}x "
              f"{stream / n_windows * 1e3:>13.3f} {per_sample_us:>13.4f} {py_push:>9.3f}")
    print("per window: stream time / windows (ARX-OE + SVM scores + indicator, samples included); "
          "per sample: a push that completes no window")


if __name__ == "__main__":
    main()
