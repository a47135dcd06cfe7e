"""Speed of the foundation's hot paths as ratios against named peers, in one run.

    python bench/file_io.py [--rows N]

- data file: mpmpp.load_data (C++ reader + validation) vs pandas.read_csv (C parser)
- data file: mpmpp.save_data vs DataFrame.to_csv
- filtering: TransferFunction.filter vs scipy.signal.lfilter (same coefficients)
A ratio > 1 means mpmpp is slower than the peer. Best of 5 repeats each.
"""
import argparse
import os
import tempfile

import numpy as np
import pandas as pd
from scipy import signal

import mpmpp
from timing import best_of


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=200_000)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)

    ts = 5.0
    model = mpmpp.Model("bench", ts, ["u1", "u2"], ["y1", "y2"])
    df = pd.DataFrame({"time": ts * np.arange(args.rows)})
    for name in ["u1", "u2", "y1", "y2", "x"]:
        df[name] = np.round(rng.normal(100.0, 5.0, args.rows), 4)

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "data.csv")
        ours = best_of(lambda: mpmpp.save_data(path, df), 5)[0]
        peer = best_of(lambda: df.to_csv(path, index=False), 5)[0]
        rows = [("write CSV", "DataFrame.to_csv", ours, peer)]
        mpmpp.save_data(path, df)
        ours = best_of(lambda: mpmpp.load_data(path, model), 5)[0]
        peer = best_of(lambda: pd.read_csv(path), 5)[0]
        rows.insert(0, ("read + validate CSV", "pandas.read_csv", ours, peer))

    g = mpmpp.TransferFunction([0.063, 0.01], [1.0, -0.93, 0.1], 14)
    x = rng.standard_normal(1_000_000)
    b = np.r_[np.zeros(g.delay), g.num]
    ours = best_of(lambda: g.filter(x), 5)[0]
    peer = best_of(lambda: signal.lfilter(b, g.den, x), 5)[0]
    rows.append(("filter 1e6 samples", "scipy.signal.lfilter", ours, peer))

    print(f"{args.rows} rows x 6 columns; best of 5")
    print(f"{'operation':<22} {'peer':<22} {'mpmpp s':>9} {'peer s':>9} {'ratio':>7}")
    for op, peer_name, t_ours, t_peer in rows:
        print(f"{op:<22} {peer_name:<22} {t_ours:9.4f} {t_peer:9.4f} {t_ours / t_peer:7.2f}")


if __name__ == "__main__":
    main()
