"""Per-solve time of mpmpp's QP solver on warm-started MPC sequences, against DAQP and OSQP.

    python bench/bench_qp.py [--solves 30000]

Families: the paper's MPC QPs, recorded at bench time from closed-loop runs of
mpmpp.scenarios.paper_siso() and paper_mimo() (--recorded consecutive samples each, taken across
the scheduled plant changes so constrained and unconstrained solves both occur); the qpbenchmark
sequences LIPMWALK and WHLIPBAL (../shared/qp/mpc_qpbenchmark, or $MPMPP_SHARED_DIR/qp/...); and
the paper-sized stand-ins of the QP tests (SISO: 4 moves; MIMO: 3 inputs x 2 moves; hard input
bounds and move limits), see tests/python/qp_reference.py::mpc_like_sequence. Each solver gets one workspace per family and is
warm-started through the sequence (mpmpp.QpSolver.solve; daqp.Model.update + solve;
osqp.OSQP.update + solve). Each sequence is repeated (from a cold start) until about --solves
solves are done, the solvers taking turns pass by pass; per-solve time = minimum over the
repeats of that solve (the machine is shared:
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
from mpmpp import scenarios  # noqa: E402
from mpmpp.simulate import run as simulate_run  # noqa: E402
from qp_reference import mpc_like_sequence  # noqa: E402
from shared_problems import QP_DIR  # noqa: E402

DAQP_INF = 1e30


def mpc_qpbenchmark(family):
    qps = []
    for k in range(30):
        d = np.load(QP_DIR / "mpc_qpbenchmark" / f"{family}{k}.npz", allow_pickle=True)
        qps.append(dict(P=d["P"], q=d["q"], A=d["G"], l=np.full(len(d["h"]), -np.inf), u=d["h"]))
    return qps


def recorded_paper_qps(spec, event, count):
    """`count` consecutive QPs of the paper scenario's closed loop (fixed P, A), ending
    2/3 of the way past the scheduled plant change at sample `event`."""
    res = simulate_run(spec, record_qps=True)
    start = max(0, min(event - count // 3, len(res.qp_q) - count))
    P, A = np.array(res.qp_P), np.array(res.qp_A)
    return [dict(P=P, q=q, A=A, l=l, u=u) for q, l, u in
            zip(res.qp_q[start:start + count], res.qp_l[start:start + count], res.qp_u[start:start + count])]


def first_gain_event(spec):
    """Sample of the scenario's first scheduled plant gain change."""
    return round(min(e["time_s"] for e in spec["events"] if e["type"] == "gain") / spec["sample_time_s"])


def stack(qps):
    return (np.array([qp["q"] for qp in qps]), np.array([qp["l"] for qp in qps]),
            np.array([qp["u"] for qp in qps]))


def per_solve(times):
    """Median over the sequence of the fastest repeat of each solve, in microseconds."""
    return 1e6 * float(np.median(np.min(np.asarray(times), axis=0)))


class MpmppRunner:
    """One warm-started pass over the sequence per call: C++-timed and Python-call-timed."""

    def __init__(self, qps):
        self.Q, self.L, self.U = stack(qps)
        self.solver = mpmpp.QpSolver(qps[0]["P"], qps[0]["A"])

    def run(self):
        cpp = self.solver.time_sequence(self.Q, self.L, self.U, 1)[0]
        self.solver.reset_warm_start()
        wall, xs = np.zeros(len(self.Q)), []
        for k in range(len(self.Q)):
            start = time.perf_counter()
            r = self.solver.solve(self.Q[k], self.L[k], self.U[k])
            wall[k] = time.perf_counter() - start
            assert r.status == "solved", (k, r.status)
            xs.append(r.x)
        return cpp, wall, np.array(xs)


class DaqpRunner:
    def __init__(self, qps):
        self.P, self.A = qps[0]["P"], qps[0]["A"]
        Q, L, U = stack(qps)
        self.Q, self.L, self.U = Q, np.clip(L, -DAQP_INF, DAQP_INF), np.clip(U, -DAQP_INF, DAQP_INF)
        self.sense = np.zeros(self.L.shape[1], dtype=np.int32)

    def run(self):
        model = daqp.Model()
        model.setup(self.P, self.Q[0], self.A, self.U[0], self.L[0], self.sense)
        self_t, wall, xs = np.zeros(len(self.Q)), np.zeros(len(self.Q)), []
        for k in range(len(self.Q)):
            start = time.perf_counter()
            if k > 0:
                model.update(f=self.Q[k], bupper=self.U[k], blower=self.L[k])
            x, _, exitflag, info = model.solve()
            wall[k] = time.perf_counter() - start
            self_t[k] = info["solve_time"]
            assert exitflag == 1, (k, exitflag)
            xs.append(np.array(x))
        return self_t, wall, np.array(xs)


class OsqpRunner:
    def __init__(self, qps):
        self.P = sp.triu(sp.csc_matrix(qps[0]["P"]), format="csc")
        self.A = sp.csc_matrix(qps[0]["A"])
        Q, L, U = stack(qps)
        self.Q, self.L, self.U = Q, np.clip(L, -1e30, 1e30), np.clip(U, -1e30, 1e30)

    def run(self):
        solver = osqp.OSQP()
        solver.setup(self.P, self.Q[0], self.A, self.L[0], self.U[0], verbose=False)
        self_t, wall = np.zeros(len(self.Q)), np.zeros(len(self.Q))
        for k in range(len(self.Q)):
            start = time.perf_counter()
            if k > 0:
                solver.update(q=self.Q[k], l=self.L[k], u=self.U[k])
            res = solver.solve(raise_error=False)
            wall[k] = time.perf_counter() - start
            self_t[k] = res.info.solve_time
        return self_t, wall, None


def time_family(qps, repeats):
    """Per-solve times {column: microseconds} and the solutions of mpmpp and DAQP. The solvers
    take turns pass by pass, so a stretch of load on the shared machine hits all of them."""
    runners = {"mpmpp": MpmppRunner(qps), "daqp": DaqpRunner(qps), "osqp": OsqpRunner(qps)}
    times = {name: ([], []) for name in runners}
    xs = {}
    for _ in range(repeats):
        for name, runner in runners.items():
            self_t, wall, x = runner.run()
            times[name][0].append(self_t)
            times[name][1].append(wall)
            xs[name] = x
    per = {name: (per_solve(a), per_solve(b)) for name, (a, b) in times.items()}
    return per, xs["mpmpp"], xs["daqp"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--solves", type=int, default=30000, help="solves per family and solver")
    parser.add_argument("--recorded", type=int, default=3000, help="consecutive recorded QPs per paper scenario")
    args = parser.parse_args()
    siso, mimo = scenarios.paper_siso(), scenarios.paper_mimo()
    families = [
        ("paper SISO (recorded)", recorded_paper_qps(siso, first_gain_event(siso), args.recorded)),
        ("paper MIMO (recorded)", recorded_paper_qps(mimo, first_gain_event(mimo), args.recorded)),
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
        per, x, x_daqp = time_family(qps, repeats)
        (cpp, py), (d_self, d_wall), (o_self, o_wall) = per["mpmpp"], per["daqp"], per["osqp"]
        dx = np.max(np.abs(x - x_daqp))
        print(f"{name:26s} {n:3d} {m:4d} {len(qps):5d} | {cpp:9.2f} {py:8.2f} | {d_self:9.2f} {d_wall:9.2f} | "
              f"{o_self:9.2f} {o_wall:9.2f} | {cpp / d_self:12.2f} {py / d_wall:11.2f} {cpp / o_self:12.2f} "
              f"{py / o_wall:11.2f} | {dx:.1e}")


if __name__ == "__main__":
    main()
