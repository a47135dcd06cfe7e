"""The QPs the paper's closed loops pose, recorded and checked with the QP references of
qp_reference.py (quadprog x, KKT duals), solved warm-started in sample order like the MPC does.

Status: every recorded QP is feasible (du = 0 with large enough slacks satisfies all rows, as
u(t-1) lies inside the hard bounds), so the right status is "solved"; a solved answer whose
primal residual is ~0 also proves that, so the LP feasibility test of check_qps (HiGHS, ~10 ms
a QP) is not needed here and the 10,000 checks stay fast."""
import numpy as np

import mpmpp
from mpmpp import scenarios
from mpmpp.simulate import run
from qp_reference import kkt_residuals, quadprog_solve


def recorded_blocks(spec, blocks):
    res = run(spec, record_qps=True)
    P, A, Q, L, U = (np.array(m) for m in (res.qp_P, res.qp_A, res.qp_q, res.qp_l, res.qp_u))
    return res, P, A, [(Q[a:b], L[a:b], U[a:b]) for a, b in blocks]


def check_sequences(P, A, sequences):
    checked = 0
    for Q, L, U in sequences:  # consecutive samples: one warm-started solver per block
        solver = mpmpp.QpSolver(P, A)
        for q, l, u in zip(Q, L, U):
            r = solver.solve(q, l, u)
            assert r.status == "solved", checked
            x_ref = quadprog_solve(P, q, A, l, u)
            err = np.linalg.norm(r.x - x_ref, np.inf) / (1.0 + np.linalg.norm(x_ref, np.inf))
            assert err <= 1e-8, (checked, err)
            assert max(kkt_residuals(P, q, A, l, u, r.x, r.y)) <= 1e-8, checked
            checked += 1
    return checked


def test_recorded_qps_of_both_scenarios_pass_the_reference_check():
    # Blocks spanning every regime: nominal, after the noise change, after each gain change.
    siso, P1, A1, seq1 = recorded_blocks(scenarios.paper_siso(), [(2000, 3000), (5000, 6500), (7900, 10400)])
    mimo, P2, A2, seq2 = recorded_blocks(scenarios.paper_mimo(),
                                         [(3000, 4000), (6900, 8000), (11990, 13500), (14990, 17000)])
    # the move limits bind in these QPs: constrained solves are among those checked
    assert np.mean(np.abs(np.diff(siso.u[7900:10400, 0])) > 0.1667 - 1e-9) > 0.01
    assert check_sequences(P1, A1, seq1) + check_sequences(P2, A2, seq2) >= 10_000
