"""mpmpp.solve_qp / mpmpp.QpSolver against independent references (see qp_reference.py):
random strictly convex QPs, warm-started sequences, Maros-Meszaros and qpbenchmark MPC problems."""
import numpy as np
import pytest
import scipy.io

import mpmpp
from shared_problems import require_qp_set
from qp_reference import check_against_reference, check_qps, kkt_residuals, mpc_like_sequence, reference_solve

INF = np.inf


def random_qp(rng):
    """A random strictly convex QP in OSQP form mixing two-sided, one-sided and infinite bounds
    (inf and 1e20), equalities, duplicated and linearly dependent rows; about one in four is made
    infeasible in one of several ways. The reference decides the status, not this generator."""
    n = int(rng.integers(1, 13))
    M = rng.standard_normal((n, n))
    P = M @ M.T + rng.choice([1e-2, 0.1, 1.0]) * np.eye(n)
    q = rng.standard_normal(n) * rng.choice([1.0, 10.0])
    x0 = rng.standard_normal(n)
    rows, lows, ups = [], [], []

    def add(a, lo, hi):
        rows.append(np.asarray(a, float)), lows.append(lo), ups.append(hi)

    for _ in range(int(rng.integers(0, 2 * n + 1))):  # inequalities around a feasible x0
        a = rng.standard_normal(n)
        c = a @ x0
        lo = c - rng.uniform(0, 1) if rng.random() > 0.25 else rng.choice([-INF, -1e20])
        hi = c + rng.uniform(0, 1) if rng.random() > 0.25 else rng.choice([INF, 1e20])
        add(a, lo, hi)
    n_eq = int(rng.integers(0, n // 2 + 1))
    eq_rows = [rng.standard_normal(n) for _ in range(n_eq)]
    for a in eq_rows:
        add(a, a @ x0, a @ x0)
    if n_eq >= 2 and rng.random() < 0.4:  # redundant equality: combination of two others
        a = 0.7 * eq_rows[0] - 1.3 * eq_rows[1]
        add(a, a @ x0, a @ x0)
    if n_eq >= 1 and rng.random() < 0.3:  # duplicated equality
        add(eq_rows[0], eq_rows[0] @ x0, eq_rows[0] @ x0)
    if rows and rng.random() < 0.5:  # duplicated (scaled) rows, same or other bounds
        for _ in range(int(rng.integers(1, 4))):
            i = int(rng.integers(len(rows)))
            s = rng.choice([1.0, 2.5])
            shift = rng.choice([0.0, rng.uniform(-0.5, 0.5)])
            add(s * rows[i], s * lows[i] + shift, s * ups[i] + shift)
    if rng.random() < 0.3:  # a tight box on some variables: many active bounds, degenerate vertices
        for j in rng.choice(n, size=int(rng.integers(1, n + 1)), replace=False):
            e = np.zeros(n)
            e[j] = 1.0
            add(e, x0[j] - 0.05, x0[j] + 0.05)

    kind = rng.random()
    if kind < 0.07:  # one direction required to be both >= c + 1 and <= c
        a = rng.standard_normal(n)
        add(a, a @ x0 + 1, INF)
        add(a, -INF, a @ x0)
    elif kind < 0.14 and n_eq >= 2:  # inconsistent redundant equality
        a = eq_rows[0] + eq_rows[1]
        add(a, a @ x0 + 0.5, a @ x0 + 0.5)
    elif kind < 0.21:  # box [0, 1]^n with sum(x) >= n + 0.5
        for j in range(n):
            e = np.zeros(n)
            e[j] = 1.0
            add(e, 0.0, 1.0)
        add(np.ones(n), n + 0.5, INF)
    elif kind < 0.27:  # a1'x >= 1, a2'x >= 1, (a1 + a2)'x <= 1.5
        a1, a2 = rng.standard_normal(n), rng.standard_normal(n)
        add(a1, 1.0, INF)
        add(a2, 1.0, INF)
        add(a1 + a2, -INF, 1.5)

    order = rng.permutation(len(rows))
    A = np.array(rows).reshape(-1, n)[order]
    return dict(P=P, q=q, A=A, l=np.array(lows, float)[order], u=np.array(ups, float)[order])


def test_random_qps_match_quadprog_and_kkt():
    rng = np.random.default_rng(20261121)
    statuses = {}
    for i in range(1200):
        qp = random_qp(rng)
        result = mpmpp.solve_qp(qp["P"], qp["q"], qp["A"], qp["l"], qp["u"])
        check_against_reference(qp, result, label=f"random QP {i}")
        statuses[result.status] = statuses.get(result.status, 0) + 1
    # The set must exercise both outcomes substantially.
    assert statuses.get("primal_infeasible", 0) >= 150, statuses
    assert statuses.get("solved", 0) >= 700, statuses


def test_warm_started_sequences_match_cold_reference():
    """Fixed P, A with q, l, u drifting (as in receding-horizon MPC), bounds switching between
    finite and infinite and equalities appearing: one solver per sequence, every solve checked."""
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(25):
        base = random_qp(rng)
        P, A = base["P"], base["A"]
        n, m = A.shape[1], A.shape[0]
        qps = []
        for _ in range(12):
            x0 = rng.standard_normal(n)
            c = A @ x0
            lo = c - rng.uniform(0, 0.3, m)
            hi = c + rng.uniform(0, 0.3, m)
            lo[rng.random(m) < 0.15] = -INF
            hi[rng.random(m) < 0.15] = 1e20
            eq = rng.random(m) < 0.1
            lo[eq] = hi[eq] = c[eq]
            qps.append(dict(P=P, q=rng.standard_normal(n), A=A, l=lo, u=hi))
        checked += check_qps(qps)
    assert checked == 300


def test_warm_start_gives_same_answer_as_cold_start():
    rng = np.random.default_rng(3)
    qp = random_qp(rng)
    while mpmpp.solve_qp(**qp).status != "solved" or qp["A"].shape[0] < 4:
        qp = random_qp(rng)
    solver = mpmpp.QpSolver(qp["P"], qp["A"])
    first = solver.solve(qp["q"], qp["l"], qp["u"])
    again = solver.solve(qp["q"], qp["l"], qp["u"])
    assert again.iterations == 0  # the previous active set is already optimal
    np.testing.assert_allclose(again.x, first.x, atol=1e-12)
    solver.reset_warm_start()
    cold = solver.solve(qp["q"], qp["l"], qp["u"])
    assert cold.iterations == first.iterations
    np.testing.assert_allclose(cold.x, first.x, atol=1e-12)


def test_unconstrained_and_zero_row_A():
    P = np.array([[4.0, 1.0], [1.0, 2.0]])
    q = np.array([1.0, -1.0])
    x_ref = np.linalg.solve(P, -q)
    for A in (np.zeros((0, 2)), np.zeros((0,)), np.zeros((0, 0))):
        r = mpmpp.solve_qp(P, q, A, np.zeros(0), np.zeros(0))
        assert r.status == "solved"
        np.testing.assert_allclose(r.x, x_ref, rtol=1e-14)
        assert r.y.shape == (0,)
        assert r.objective == pytest.approx(0.5 * x_ref @ P @ x_ref + q @ x_ref, rel=1e-14)


def test_duals_follow_osqp_sign_convention():
    # min 1/2|x|^2 - x1 - x2  s.t.  x1 <= 0.5 (upper active: y > 0), x2 >= 2 (lower active: y < 0)
    P, q = np.eye(2), np.array([-1.0, -1.0])
    A = np.eye(2)
    r = mpmpp.solve_qp(P, q, A, np.array([-INF, 2.0]), np.array([0.5, INF]))
    np.testing.assert_allclose(r.x, [0.5, 2.0], atol=1e-14)
    np.testing.assert_allclose(r.y, [0.5, -1.0], atol=1e-14)  # P x + q + A'y = 0


def test_status_non_convex_and_max_iterations():
    A, l, u = np.eye(2), -np.ones(2), np.ones(2)
    for P in (np.diag([1.0, -1.0]), np.diag([1.0, 0.0])):
        assert mpmpp.solve_qp(P, np.ones(2), A, l, u).status == "non_convex"
    # Needs two active bounds, so one iteration is not enough; the iterate is returned.
    r = mpmpp.solve_qp(np.eye(2), np.array([-5.0, -5.0]), A, l, u, max_iterations=1)
    assert r.status == "max_iterations" and r.iterations == 1 and r.x.shape == (2,)


def test_bad_input_names_the_argument():
    P, A = np.eye(2), np.eye(2)
    ok = np.zeros(2)
    with pytest.raises(ValueError, match="q has 3"):
        mpmpp.solve_qp(P, np.zeros(3), A, ok, ok)
    with pytest.raises(ValueError, match=r"l\[1\] > u\[1\]"):
        mpmpp.solve_qp(P, ok, A, np.array([0.0, 2.0]), np.array([1.0, 1.0]))
    with pytest.raises(ValueError, match="l\\[0\\] is NaN"):
        mpmpp.solve_qp(P, ok, A, np.array([np.nan, 0.0]), ok)
    with pytest.raises(ValueError, match=r"l\[0\] is \+infinite"):
        mpmpp.solve_qp(P, ok, A, np.array([np.inf, 0.0]), np.array([np.inf, 0.0]))
    with pytest.raises(ValueError, match="A has 3 columns"):
        mpmpp.solve_qp(P, ok, np.ones((2, 3)), ok, ok)
    with pytest.raises(ValueError, match="P must be square"):
        mpmpp.QpSolver(np.ones((2, 3)), A)
    with pytest.raises(ValueError, match="P has a NaN"):
        mpmpp.QpSolver(np.array([[1.0, np.nan], [np.nan, 1.0]]), A)


MAROS_MESZAROS_PD = ["DUAL1", "DUAL2", "DUAL3", "DUAL4", "DUALC1", "DUALC5", "HS21", "HS35",
                     "HS35MOD", "HS76", "HS118", "HS268", "QPCBLEND"]
MAROS_MESZAROS_PSD = ["GENHS28", "HS51", "HS52", "HS53", "LOTSCHD", "QAFIRO", "QADLITTL", "TAME",
                      "ZECEVIC2", "DUALC2", "DUALC8"]


def load_maros_meszaros(name):
    d = scipy.io.loadmat(str(require_qp_set("maros_meszaros") / f"{name}.mat"))
    def dense(M):
        return M.toarray() if hasattr(M, "toarray") else np.asarray(M, float)
    return dict(P=dense(d["P"]), q=d["q"].ravel().astype(float), A=dense(d["A"]),
                l=d["l"].ravel().astype(float), u=d["u"].ravel().astype(float), r=float(d["r"].ravel()[0]))


@pytest.mark.parametrize("name", MAROS_MESZAROS_PD)
def test_maros_meszaros_positive_definite(name):
    qp = load_maros_meszaros(name)
    r = mpmpp.solve_qp(qp["P"], qp["q"], qp["A"], qp["l"], qp["u"])
    assert r.status == "solved"
    x_ref = reference_solve(qp["P"], qp["q"], qp["A"], qp["l"], qp["u"])
    f_ref = 0.5 * x_ref @ qp["P"] @ x_ref + qp["q"] @ x_ref + qp["r"]
    assert r.objective + qp["r"] == pytest.approx(f_ref, rel=1e-6, abs=1e-9)
    primal, stationarity, sign, complementarity = kkt_residuals(qp["P"], qp["q"], qp["A"], qp["l"], qp["u"], r.x, r.y)
    assert max(primal, stationarity, sign, complementarity) < 1e-7


@pytest.mark.parametrize("name", MAROS_MESZAROS_PSD)
def test_maros_meszaros_semidefinite_is_reported_non_convex(name):
    qp = load_maros_meszaros(name)
    assert np.linalg.eigvalsh(qp["P"]).min() <= 1e-12 * np.abs(qp["P"]).max()  # truly singular
    assert mpmpp.solve_qp(qp["P"], qp["q"], qp["A"], qp["l"], qp["u"]).status == "non_convex"


def load_mpc_family(family):
    folder, qps = require_qp_set("mpc_qpbenchmark"), []
    for k in range(30):
        d = np.load(folder / f"{family}{k}.npz", allow_pickle=True)
        G, h = d["G"], d["h"]
        qps.append(dict(P=d["P"], q=d["q"], A=G, l=np.full(len(h), -INF), u=h))
    return qps


@pytest.mark.parametrize("family", ["LIPMWALK", "WHLIPBAL"])
def test_mpc_qpbenchmark_sequences_warm_started(family):
    qps = load_mpc_family(family)
    assert all(np.array_equal(qp["P"], qps[0]["P"]) and np.array_equal(qp["A"], qps[0]["A"]) for qp in qps)
    assert check_qps(qps) == 30


@pytest.mark.parametrize("n_mv, n_moves", [(1, 4), (3, 2)])
def test_mpc_like_closed_loop_sequences(n_mv, n_moves):
    """Paper-sized stand-ins (SISO: 4 moves; MIMO: 3 inputs x 2 moves) with duplicated rows."""
    qps = mpc_like_sequence(n_mv, n_moves, n_steps=400, seed=11 + n_mv)
    binding = np.mean([np.any(mpmpp.solve_qp(**qp).y != 0.0) for qp in qps])
    assert 0.2 < binding < 0.9, binding  # constraints bind in part of the run, not all of it
    assert check_qps(qps) == 400


def test_highly_degenerate_vertices_do_not_cycle():
    """Many rows (copies, scaled copies, sums of bound rows) all tight at the same vertex: the
    dependent ones must be recognised and the solve end well inside the iteration cap."""
    rng = np.random.default_rng(5)
    for trial in range(60):
        n = int(rng.integers(2, 9))
        vertex = rng.standard_normal(n)
        E = np.eye(n)
        rows = [E, E, 3.0 * E, np.ones((1, n)), E[:1] + E[-1:], rng.standard_normal((n, n))]
        A = np.vstack(rows)
        c = A @ vertex
        l = c - rng.choice([0.0, 1.0], size=len(c))  # most rows tight from below or above
        u = np.where(l == c, c + rng.choice([0.0, 1.0], size=len(c)), c)
        M = rng.standard_normal((n, n))
        qp = dict(P=M @ M.T + 0.1 * np.eye(n), q=10.0 * rng.standard_normal(n), A=A, l=l, u=u)
        result = mpmpp.solve_qp(**qp, max_iterations=50 * n)
        assert result.status != "max_iterations", trial
        check_against_reference(qp, result, label=f"degenerate {trial}")
