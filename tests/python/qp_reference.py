"""Reference solutions for QPs in OSQP form (min 1/2 x'Px + q'x s.t. l <= Ax <= u) and the checks
the solver's answers must pass. Reusable: `check_qps(qps)` runs a list of recorded QPs (dicts with
keys P, q, A, l, u) through mpmpp and compares each against the references.

References, all independent of mpmpp:
- feasibility (the status): SciPy's HiGHS LP `linprog` on l <= Ax <= u;
- x: quadprog (Goldfarb-Idnani in Fortran), after removing linearly dependent equality rows,
  which quadprog cannot take (it reports them as inconsistent);
- duals: the KKT conditions checked directly with NumPy (stationarity, sign and complementarity).
"""
import os
from pathlib import Path

import numpy as np
import quadprog
import scipy.linalg
from scipy.optimize import linprog

INFINITE_BOUND = 1e20
# The shared data lives beside the repository (CI clones it there); MPMPP_SHARED_DIR overrides.
SHARED_DIR = Path(os.environ.get("MPMPP_SHARED_DIR", Path(__file__).resolve().parents[2].parent / "shared"))


def _finite(v):
    return np.abs(v) < INFINITE_BOUND


def is_feasible(A, l, u):
    """Whether {x : l <= Ax <= u} is non-empty, by a HiGHS LP with a zero objective."""
    m, n = A.shape
    if m == 0:
        return True
    lo, hi = _finite(l), _finite(u)
    eq = lo & hi & (l == u)
    A_ub = np.vstack([A[hi & ~eq], -A[lo & ~eq]])
    b_ub = np.concatenate([u[hi & ~eq], -l[lo & ~eq]])
    res = linprog(np.zeros(n), A_ub=A_ub if len(b_ub) else None, b_ub=b_ub if len(b_ub) else None,
                  A_eq=A[eq] if eq.any() else None, b_eq=l[eq] if eq.any() else None,
                  bounds=[(None, None)] * n, method="highs")
    if res.status not in (0, 2):
        raise RuntimeError(f"linprog could not decide feasibility: {res.message}")
    return res.status == 0


def quadprog_solve(P, q, A, l, u):
    """x of the QP by quadprog; equality rows reduced to an independent, consistent subset."""
    n = P.shape[0]
    lo, hi = _finite(l), _finite(u)
    eq = lo & hi & (l == u)
    Aeq, beq = A[eq], l[eq]
    if len(beq):
        # Rank-revealing QR of Aeq': keep the pivot rows that are independent.
        _, R, piv = scipy.linalg.qr(Aeq.T, mode="economic", pivoting=True)
        diag = np.abs(np.diag(R))
        rank = int(np.sum(diag > 1e-10 * max(diag.max(), 1.0))) if diag.size else 0
        keep = np.sort(piv[:rank])
        Aeq, beq = Aeq[keep], beq[keep]
    C = np.vstack([Aeq, A[lo & ~eq], -A[hi & ~eq]]).T.reshape(n, -1)
    b = np.concatenate([beq, l[lo & ~eq], -u[hi & ~eq]])
    if len(b) == 0:  # quadprog needs at least one constraint
        return np.linalg.solve(P, -q)
    return quadprog.solve_qp(P, -q, C, b, len(beq))[0]


def kkt_residuals(P, q, A, l, u, x, y):
    """Scaled KKT residuals of (x, y) in OSQP's convention (Px + q + A'y = 0, y_i > 0 at u_i,
    y_i < 0 at l_i, y_i = 0 strictly inside): (primal, stationarity, sign, complementarity)."""
    Ax = A @ x
    lo, hi = _finite(l), _finite(u)
    scale = 1.0 + np.max(np.abs(np.concatenate([Ax, l[lo], u[hi], [0.0]])))
    primal = max(np.max(np.concatenate([(l - Ax)[lo], (Ax - u)[hi], [0.0]])), 0.0) / scale
    grad = P @ x + q
    stationarity = np.linalg.norm(grad + A.T @ y, np.inf) / (1.0 + np.linalg.norm(grad, np.inf))
    ynorm = 1.0 + np.linalg.norm(y, np.inf)
    # y_i > 0 needs a finite upper bound, y_i < 0 a finite lower one.
    sign = max(np.max(np.concatenate([y[~hi], [0.0]])), np.max(np.concatenate([-y[~lo], [0.0]])), 0.0) / ynorm
    comp_u = np.where(hi & (y > 0), np.maximum(y, 0) * np.abs(np.where(hi, u, 0) - Ax), 0.0)
    comp_l = np.where(lo & (y < 0), np.maximum(-y, 0) * np.abs(Ax - np.where(lo, l, 0)), 0.0)
    complementarity = np.max(np.concatenate([comp_u, comp_l, [0.0]])) / (ynorm * scale)
    return primal, stationarity, sign, complementarity


def check_against_reference(qp, result, x_tol=1e-8, kkt_tol=1e-8, label=""):
    """Assert that an mpmpp result for one QP (dict P, q, A, l, u) is right: the status agrees
    with the LP feasibility test and, when solved, x matches quadprog and (x, y) satisfy KKT."""
    P, q, A, l, u = (np.asarray(qp[k], dtype=float) for k in ("P", "q", "A", "l", "u"))
    A = A.reshape(-1, P.shape[0])
    feasible = is_feasible(A, l, u)
    expected = "solved" if feasible else "primal_infeasible"
    assert result.status == expected, f"{label}: status {result.status}, expected {expected}"
    if not feasible:
        return
    x_ref = quadprog_solve(P, q, A, l, u)
    err = np.linalg.norm(result.x - x_ref, np.inf) / (1.0 + np.linalg.norm(x_ref, np.inf))
    assert err <= x_tol, f"{label}: |x - x_quadprog| = {err:.2e} (relative)"
    residuals = kkt_residuals(P, q, A, l, u, result.x, result.y)
    assert max(residuals) <= kkt_tol, f"{label}: KKT residuals {residuals}"


def check_qps(qps, solver_factory=None, **kwargs):
    """Solve a list of QPs (dicts P, q, A, l, u) in order and check each against the reference.
    QPs sharing P and A (like an MPC's) go through one warm-started mpmpp.QpSolver; pass
    `solver_factory(P, A)` to use other settings. Returns the number of QPs checked."""
    import mpmpp

    factory = solver_factory or (lambda P, A: mpmpp.QpSolver(P, A))
    solver, key = None, None
    for i, qp in enumerate(qps):
        P = np.asarray(qp["P"], dtype=float)
        A = np.asarray(qp["A"], dtype=float).reshape(-1, P.shape[0])
        if solver is None or key is None or not (np.array_equal(key[0], P) and np.array_equal(key[1], A)):
            solver, key = factory(P, A), (P, A)
        result = solver.solve(np.asarray(qp["q"], float), np.asarray(qp["l"], float), np.asarray(qp["u"], float))
        check_against_reference(qp, result, label=f"QP {i}", **kwargs)
    return len(qps)
