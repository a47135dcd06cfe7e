"""Long correctness study of mpmpp.solve_qp (kept out of the test suite for time):

    python studies/stress_qp.py [--count 3000] [--seed 1] [--family small|large]

small: the generator of tests/python/test_qp.py (n <= 12; equalities, duplicated and redundant
rows, infinite bounds, infeasible cases). large: n up to 40, m up to 3n, P with condition number
up to 1e6, half of the problems with rank-deficient A (many linearly dependent rows), bounds tight
around a feasible point. Every QP is checked like the tests do (status by a HiGHS LP, x against
quadprog or polished OSQP to 1e-8, duals by the KKT conditions); failures are printed.
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "python"))
sys.path.insert(0, str(ROOT / "tests" / "python"))

import mpmpp  # noqa: E402
from qp_reference import check_against_reference  # noqa: E402
from test_qp import random_qp  # noqa: E402


def large_qp(rng):
    n = int(rng.integers(5, 41))
    m = int(rng.integers(0, 3 * n))
    U, _ = np.linalg.qr(rng.standard_normal((n, n)))
    P = (U * np.logspace(0, rng.uniform(0, 6), n)) @ U.T
    P = 0.5 * (P + P.T)
    q = 10.0 * rng.standard_normal(n)
    A = rng.standard_normal((m, n))
    if m > 3 and rng.random() < 0.5:  # rank n/3: most rows depend on others
        k = max(1, n // 3)
        A = rng.standard_normal((m, k)) @ rng.standard_normal((k, n))
    c = A @ rng.standard_normal(n)
    l = c - rng.uniform(0, 0.1, m) * (rng.random(m) > 0.3)
    u = c + rng.uniform(0, 0.1, m) * (rng.random(m) > 0.3)
    l[rng.random(m) < 0.2] = -np.inf
    u[rng.random(m) < 0.2] = np.inf
    return dict(P=P, q=q, A=A, l=l, u=u)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=3000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--family", choices=["small", "large"], default="large")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    generate = large_qp if args.family == "large" else random_qp
    failures, statuses, start = 0, {}, time.time()
    for i in range(args.count):
        qp = generate(rng)
        result = mpmpp.solve_qp(**qp)
        statuses[result.status] = statuses.get(result.status, 0) + 1
        try:
            check_against_reference(qp, result, label=f"QP {i}")
        except AssertionError as error:
            failures += 1
            print(f"FAIL {error} (n={qp['P'].shape[0]}, m={qp['A'].shape[0]}, iterations={result.iterations})")
    print(f"{args.count} QPs ({args.family}, seed {args.seed}): {failures} failures, statuses {statuses}, "
          f"{time.time() - start:.0f} s")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
