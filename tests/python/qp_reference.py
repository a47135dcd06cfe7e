"""Reference solutions for QPs in OSQP form (min 1/2 x'Px + q'x s.t. l <= Ax <= u) and the checks
the solver's answers must pass. Reusable: `check_qps(qps)` runs a list of recorded QPs (dicts with
keys P, q, A, l, u) through mpmpp and compares each against the references.

References, all independent of mpmpp:
- feasibility (the status): SciPy's HiGHS LP `linprog` on l <= Ax <= u;
- x: quadprog (Goldfarb-Idnani in Fortran), after removing linearly dependent equality rows,
  which quadprog cannot take (it reports them as inconsistent); where quadprog still gives up on
  a feasible problem (it also stumbles over dependent inequality rows) or its answer fails its
  own stationarity check (ill-conditioned P), OSQP at eps 1e-10 with solution polishing;
- duals: the KKT conditions checked directly with NumPy (stationarity, sign and complementarity).
"""

import numpy as np
import quadprog
import scipy.linalg
from scipy.optimize import linprog

INFINITE_BOUND = 1e20


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


def osqp_solve(P, q, A, l, u):
    """x of the QP by OSQP at high accuracy with polishing (the fallback reference)."""
    import osqp
    import scipy.sparse as sp

    solver = osqp.OSQP()
    solver.setup(sp.triu(sp.csc_matrix(P), format="csc"), q, sp.csc_matrix(A),
                 np.clip(l, -1e30, 1e30), np.clip(u, -1e30, 1e30), eps_abs=1e-10, eps_rel=1e-10,
                 polishing=True, max_iter=200000, eps_prim_inf=1e-15, eps_dual_inf=1e-15, verbose=False)
    res = solver.solve(raise_error=False)
    if res.info.status != "solved":
        raise RuntimeError(f"OSQP reference failed: {res.info.status}")
    return res.x


def reference_solve(P, q, A, l, u):
    """x of a feasible QP: quadprog, or polished OSQP where quadprog reports dependent rows as
    inconsistent or its own answer is not stationary to 1e-9 (it loses digits on ill-conditioned P)."""
    try:
        return quadprog_solve(P, q, A, l, u)
    except (ValueError, ArithmeticError):
        return osqp_solve(P, q, A, l, u)


def quadprog_solve(P, q, A, l, u):
    """x of the QP by quadprog; equality rows reduced to an independent, consistent subset.
    Raises ArithmeticError when quadprog's (x, multipliers) are not stationary to 1e-9."""
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
    x, _, _, _, multipliers, _ = quadprog.solve_qp(P, -q, C, b, len(beq))
    grad = P @ x + q
    if np.linalg.norm(grad - C @ multipliers, np.inf) > 1e-9 * (1.0 + np.linalg.norm(grad, np.inf)):
        raise ArithmeticError("quadprog's answer is not stationary")
    return x


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
    with the LP feasibility test and, when solved, x matches the reference and (x, y) satisfy KKT."""
    P, q, A, l, u = (np.asarray(qp[k], dtype=float) for k in ("P", "q", "A", "l", "u"))
    A = A.reshape(-1, P.shape[0])
    feasible = is_feasible(A, l, u)
    expected = "solved" if feasible else "primal_infeasible"
    assert result.status == expected, f"{label}: status {result.status}, expected {expected}"
    if not feasible:
        return
    x_ref = reference_solve(P, q, A, l, u)
    err = np.linalg.norm(result.x - x_ref, np.inf) / (1.0 + np.linalg.norm(x_ref, np.inf))
    assert err <= x_tol, f"{label}: |x - x_reference| = {err:.2e} (relative)"
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


def mpc_like_sequence(n_mv, n_moves, n_steps, seed, horizon=20):
    """Recorded QPs of a receding-horizon MPC in condensed form (variables: the n_moves future
    moves of each of n_mv inputs), a stand-in for the paper's controllers: first-order channels
    (n_mv outputs), tracking + move + input-target weights, hard input bounds and move limits as
    rows [T; I] of A (T sums moves into inputs, so its first row per input duplicates a move
    row). The loop is closed on a plant with a random-walk output disturbance and setpoint steps,
    solved with mpmpp, and every QP is returned as a dict P, q, A, l, u."""
    import mpmpp

    rng = np.random.default_rng(seed)
    n_cv = n_mv
    gain = rng.uniform(0.5, 2.0, (n_cv, n_mv)) * rng.choice([-1.0, 1.0], (n_cv, n_mv))
    gain[np.diag_indices(n_cv)] = np.abs(gain[np.diag_indices(n_cv)]) + 1.0  # dominant diagonal
    pole = rng.uniform(0.7, 0.95, (n_cv, n_mv))
    # Step response of channel (i, j) after k+1 samples: gain (1 - pole^(k+1)).
    def step(k):
        return gain * (1.0 - pole ** (k + 1))
    n = n_mv * n_moves
    # Y (horizon x n_cv, stacked by time) = free + S dU, dU stacked as [input j, move k].
    S = np.zeros((horizon * n_cv, n))
    for t in range(horizon):
        for k in range(min(t + 1, n_moves)):
            S[t * n_cv:(t + 1) * n_cv, [j * n_moves + k for j in range(n_mv)]] = step(t - k)
    T = np.kron(np.eye(n_mv), np.tril(np.ones((n_moves, n_moves))))
    w_move, w_target = 0.5, 0.01
    P = 2.0 * (S.T @ S + w_move * np.eye(n) + w_target * T.T @ T)
    A = np.vstack([T, np.eye(n)])
    u_max, move_max = 1.0, 0.1
    state = np.zeros((n_cv, n_mv))  # first-order channel outputs
    u_prev = np.zeros(n_mv)
    disturbance = np.zeros(n_cv)
    setpoint = np.zeros(n_cv)
    solver = mpmpp.QpSolver(P, A)
    qps = []
    for k in range(n_steps):
        if k % 40 == 0:
            setpoint = rng.uniform(-3.0, 3.0, n_cv)
        disturbance += 0.02 * rng.standard_normal(n_cv)
        # Free response: channels decay towards gain * u_prev from the current state.
        free = np.concatenate([(gain * u_prev + pole ** (t + 1) * (state - gain * u_prev)).sum(axis=1)
                               + disturbance for t in range(horizon)])
        error = free - np.tile(setpoint, horizon)
        q = 2.0 * (S.T @ error + w_target * T.T @ np.repeat(u_prev, n_moves))
        l = np.concatenate([np.repeat(-u_max - u_prev, n_moves), np.full(n, -move_max)])
        u = np.concatenate([np.repeat(u_max - u_prev, n_moves), np.full(n, move_max)])
        qps.append(dict(P=P, q=q, A=A, l=l, u=u))
        result = solver.solve(q, l, u)
        if result.status != "solved":
            raise RuntimeError(f"stand-in MPC QP {k}: {result.status}")
        u_prev = u_prev + result.x[::n_moves]
        state = pole * state + (1.0 - pole) * gain * u_prev
    return qps
