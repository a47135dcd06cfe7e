"""Instructions per warm solve of mpmpp's QP solver on the paper's recorded MPC QPs (callgrind).

    python bench/callgrind_qp.py [--recorded 3000]

Records the same QP sequences as bench/bench_qp.py (closed-loop runs of paper_siso() and
paper_mimo() across the first plant-gain change), replays each once through
QpSolver.time_sequence under `valgrind --tool=callgrind`, collecting only inside
QpSolver::solve, and prints the instruction count divided by the number of solves. Unlike
wall time this does not depend on the load of the (shared) machine. Needs valgrind on PATH.
"""
import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))
sys.path.insert(0, str(BENCH.parent / "python"))

import mpmpp  # noqa: E402


def replay(path):
    d = np.load(path)
    mpmpp.QpSolver(d["P"], d["A"]).time_sequence(d["Q"], d["L"], d["U"], 1)


def instructions_per_solve(path, solves):
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                        "--toggle-collect=mpmpp::QpSolver::solve*", sys.executable, __file__, "--replay", str(path)],
                       check=True, capture_output=True)
        total = int(re.search(r"^(?:summary|totals): (\d+)", out.read_text(), re.M).group(1))
    return total / solves


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recorded", type=int, default=3000, help="consecutive recorded QPs per paper scenario")
    parser.add_argument("--replay", help=argparse.SUPPRESS)  # internal: the process run under valgrind
    args = parser.parse_args()
    if args.replay:
        replay(args.replay)
        return
    if shutil.which("valgrind") is None:
        sys.exit("valgrind is not on PATH")
    from bench_qp import first_gain_event, recorded_paper_qps, stack
    from mpmpp import scenarios

    print("instructions per warm solve inside QpSolver::solve (callgrind)")
    with tempfile.TemporaryDirectory() as tmp:
        for name, spec in [("paper SISO (recorded)", scenarios.paper_siso()), ("paper MIMO (recorded)", scenarios.paper_mimo())]:
            qps = recorded_paper_qps(spec, first_gain_event(spec), args.recorded)
            Q, L, U = stack(qps)
            path = Path(tmp) / "qps.npz"
            np.savez(path, P=qps[0]["P"], A=qps[0]["A"], Q=Q, L=L, U=U)
            n, m = qps[0]["A"].shape[1], qps[0]["A"].shape[0]
            print(f"{name:24s} n={n:3d} m={m:4d} N={len(qps):5d}: {instructions_per_solve(path, len(qps)):9.0f}")


if __name__ == "__main__":
    main()
