"""Per-solve time of mpmpp's QP solver on warm-started MPC sequences, against DAQP and OSQP.

    python bench/bench_qp.py [--solves 30000]

Families: the qpbenchmark sequences LIPMWALK and WHLIPBAL (../shared/qp/mpc_qpbenchmark, or
$MPMPP_SHARED_DIR/qp/...), and paper-sized stand-ins (SISO: 4 moves; MIMO: 3 inputs x 2 moves;
hard input bounds and move limits) recorded from a closed loop, see
tests/python/qp_reference.py::mpc_like_sequence. Each solver gets one workspace per family and is
warm-started through the sequence (mpmpp.QpSolver.solve; daqp.Model.update + solve;
osqp.OSQP.update + solve). Each sequence is repeated (from a cold start) until about --solves
solves are done; per-solve time = minimum over the repeats of that solve (the machine is shared:
the minimum filters out preemption), then the median over the sequence. Columns:
  mpmpp C++     time of QpSolver::solve measured inside C++ (QpSolver.time_sequence)
  mpmpp py      wall time around the Python call solver.solve(q, l, u)
  DAQP self     DAQP's self-reported info["solve_time"] (excludes its update of f, b)
  DAQP wall     wall time around the Python calls model.update(...) + model.solve()
  OSQP self     OSQP's self-reported info.solve_time (default settings, eps 1e-3)
  OSQP wall     wall time around osqp update(...) + solve()
Ratios < 1 mean mpmpp is faster. Also printed: the largest |x - x_DAQP| over the sequence.
"""
import argparse
import sys
import time
from pathlib import Path

import daqp
import numpy as np
import osqp
import scipy.sparse as sp

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "python"))
sys.path.insert(0, str(ROOT / "tests" / "python"))

import mpmpp  # noqa: E402
from qp_reference import SHARED_DIR, mpc_like_sequence  # noqa: E402

DAQP_INF = 1e30


def mpc_qpbenchmark(family):
    qps = []
    for k in range(30):
        d = np.load(SHARED_DIR / "qp" / "mpc_qpbenchmark" / f"{family}{k}.npz", allow_pickle=True)
        qps.append(dict(P=d["P"], q=d["q"], A=d["G"], l=np.full(len(d["h"]), -np.inf), u=d["h"]))
    return qps


def stack(qps):
    return (np.array([qp["q"] for qp in qps]), np.array([qp["l"] for qp in qps]),
            np.array([qp["u"] for qp in qps]))


def per_solve(times):
    """Median over the sequence of the fastest repeat of each solve, in microseconds."""
    return 1e6 * float(np.median(np.min(np.asarray(times), axis=0)))


def time_mpmpp(qps, repeats):
    P, A = qps[0]["P"], qps[0]["A"]
    Q, L, U = stack(qps)
    solver = mpmpp.QpSolver(P, A)
    cpp = solver.time_sequence(Q, L, U, repeats)
    wall = np.zeros((repeats, len(qps)))
    xs = []
    for rep in range(repeats):
        solver.reset_warm_start()
        for k in range(len(qps)):
            start = time.perf_counter()
            r = solver.solve(Q[k], L[k], U[k])
            wall[rep, k] = time.perf_counter() - start
            if rep == 0:
                assert r.status == "solved", (k, r.status)
                xs.append(r.x)
    return per_solve(cpp), per_solve(wall), np.array(xs)


def time_daqp(qps, repeats):
    P, A = qps[0]["P"], qps[0]["A"]
    Q, L, U = stack(qps)
    L, U = np.clip(L, -DAQP_INF, DAQP_INF), np.clip(U, -DAQP_INF, DAQP_INF)
    sense = np.zeros(len(L[0]), dtype=np.int32)
    self_t = np.zeros((repeats, len(qps)))
    wall = np.zeros((repeats, len(qps)))
    xs = []
    for rep in range(repeats):
        model = daqp.Model()
        model.setup(P, Q[0], A, U[0], L[0], sense)
        for k in range(len(qps)):
            start = time.perf_counter()
            if k > 0:
                model.update(f=Q[k], bupper=U[k], blower=L[k])
            x, _, exitflag, info = model.solve()
            wall[rep, k] = time.perf_counter() - start
            self_t[rep, k] = info["solve_time"]
            if rep == 0:
                assert exitflag == 1, (k, exitflag)
                xs.append(np.array(x))
    return per_solve(self_t), per_solve(wall), np.array(xs)


def time_osqp(qps, repeats):
    P, A = sp.triu(sp.csc_matrix(qps[0]["P"]), format="csc"), sp.csc_matrix(qps[0]["A"])
    Q, L, U = stack(qps)
    L, U = np.clip(L, -1e30, 1e30), np.clip(U, -1e30, 1e30)
    self_t = np.zeros((repeats, len(qps)))
    wall = np.zeros((repeats, len(qps)))
    for rep in range(repeats):
        solver = osqp.OSQP()
        solver.setup(P, Q[0], A, L[0], U[0], verbose=False)
        for k in range(len(qps)):
            start = time.perf_counter()
            if k > 0:
                solver.update(q=Q[k], l=L[k], u=U[k])
            res = solver.solve(raise_error=False)
            wall[rep, k] = time.perf_counter() - start
            self_t[rep, k] = res.info.solve_time
    return per_solve(self_t), per_solve(wall)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--solves", type=int, default=30000, help="solves per family and solver")
    args = parser.parse_args()
    families = [
        ("LIPMWALK (qpbenchmark)", mpc_qpbenchmark("LIPMWALK")),
        ("WHLIPBAL (qpbenchmark)", mpc_qpbenchmark("WHLIPBAL")),
        ("SISO stand-in, 4 moves", mpc_like_sequence(1, 4, n_steps=1000, seed=1)),
        ("MIMO stand-in, 3x2 moves", mpc_like_sequence(3, 2, n_steps=1000, seed=2)),
    ]
    print("per-solve time in microseconds (median over the sequence of each solve's best repeat)")
    header = (f"{'family':26s} {'n':>3s} {'m':>4s} {'N':>5s} | {'mpmpp C++':>9s} {'mpmpp py':>8s} | "
              f"{'DAQP self':>9s} {'DAQP wall':>9s} | {'OSQP self':>9s} {'OSQP wall':>9s} | "
              f"{'C++/DAQPself':>12s} {'py/DAQPwall':>11s} {'C++/OSQPself':>12s} {'py/OSQPwall':>11s} | max|dx|")
    print(header)
    print("-" * len(header))
    for name, qps in families:
        n, m = qps[0]["A"].shape[1], qps[0]["A"].shape[0]
        repeats = max(3, args.solves // len(qps))
        cpp, py, x = time_mpmpp(qps, repeats)
        d_self, d_wall, x_daqp = time_daqp(qps, repeats)
        o_self, o_wall = time_osqp(qps, repeats)
        dx = np.max(np.abs(x - x_daqp))
        print(f"{name:26s} {n:3d} {m:4d} {len(qps):5d} | {cpp:9.2f} {py:8.2f} | {d_self:9.2f} {d_wall:9.2f} | "
              f"{o_self:9.2f} {o_wall:9.2f} | {cpp / d_self:12.2f} {py / d_wall:11.2f} {cpp / o_self:12.2f} "
              f"{py / o_wall:11.2f} | {dx:.1e}")


if __name__ == "__main__":
    main()
