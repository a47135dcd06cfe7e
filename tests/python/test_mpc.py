"""The MPC against a NumPy implementation of the same condensed formulation
(reference_mpc.py) and its QPs against quadprog."""
import numpy as np
import pytest
import quadprog

from mpmpp import _core
from reference_mpc import NumpyMpc

TF = _core.TransferFunction
INF = np.inf
# 2x2 with delays, a missing channel, a numerator with a leading zero and a second-order pole.
PROCESS = [
    [([0.5], [1, -0.8], 3), ([0.0, 0.2, 0.1], [1, -0.5], 2)],
    [None, ([-0.3], [1, -0.7, 0.1], 5)],
]
U0 = np.array([10.0, 20.0])


NOISE = [([1.0, -0.3], [1.0, 0.6]), ([1.0, 0.2], [1.0, -0.5, 0.06])]


def core_model(process=None):
    channels = {f"y{i + 1}": {f"u{j + 1}": TF(*g) for j, g in enumerate(row) if g}
                for i, row in enumerate(PROCESS)}
    noise = {f"y{i + 1}": TF(*h) for i, h in enumerate(NOISE)}
    return _core.Model("test", 1.0, ["u1", "u2"], ["y1", "y2"], channels if process is None else process, noise)


def tuning(hp=8, hc=3, mv_min=(-INF, -INF), mv_max=(INF, INF), max_move=(INF, INF), **extra):
    t = _core.MpcTuning()
    t.prediction_horizon, t.control_horizon = hp, hc
    t.cv_target = [1.0, -2.0]
    t.mv_target = [10.5, 19.0]
    t.cv_target_weight = [1.0, 2.0]
    t.mv_target_weight = [0.3, 0.1]
    t.move_weight = [0.05, 0.1]
    t.deviation_weight = [0.02, 0.0]
    t.mv_min, t.mv_max, t.mv_max_move = list(mv_min), list(mv_max), list(max_move)
    for k, v in extra.items():
        setattr(t, k, v)
    return t


def reference(t):
    noise = NOISE if t.disturbance == _core.DisturbanceModel.noise_model else None
    return NumpyMpc(PROCESS, t.prediction_horizon, t.control_horizon, t.cv_target, t.mv_target,
                    t.cv_target_weight, t.mv_target_weight, t.move_weight, t.deviation_weight,
                    t.mv_min, t.mv_max, t.mv_max_move, U0, noise)


def measurements(n, scale, seed):
    return np.array([1.0, -2.0]) + scale * np.random.default_rng(seed).standard_normal((n, 2))


@pytest.mark.parametrize("disturbance", ["bias", "noise_model"])
def test_unconstrained_steps_equal_numpy_formulation(disturbance):
    t = tuning(disturbance=getattr(_core.DisturbanceModel, disturbance))
    mpc, ref = _core.Mpc(core_model(), t, U0), reference(t)
    assert np.allclose(mpc.dynamic_matrix, ref.theta, atol=1e-14)
    assert np.allclose(mpc.P, ref.P, rtol=1e-12, atol=1e-14)
    assert list(mpc.prediction_start) == [3, 5]  # G12: delay 2 + a leading zero; G22: 5
    for y in measurements(80, 0.5, seed=1):
        u = mpc.step(y)
        u_ref = ref.step(y, constrained=False)
        assert np.allclose(mpc.disturbance_estimate, ref.dist, atol=1e-10)
        assert np.allclose(mpc.free_response, ref.f, atol=1e-9)
        assert np.allclose(u, u_ref, rtol=0, atol=1e-8), (u, u_ref)


def test_constrained_steps_equal_quadprog():
    t = tuning(mv_min=(9.6, 19.5), mv_max=(10.4, 20.3), max_move=(0.05, 0.08))
    mpc, ref = _core.Mpc(core_model(), t, U0), reference(t)
    active = 0
    for y in measurements(150, 2.0, seed=2):
        u_prev = mpc.u.copy()
        u = mpc.step(y)
        u_ref = ref.step(y)
        assert mpc.status == "solved"
        assert np.allclose(u, u_ref, rtol=0, atol=1e-7), (u, u_ref)
        assert np.all(u >= t.mv_min - 1e-9) and np.all(u <= t.mv_max + 1e-9)
        assert np.all(np.abs(u - u_prev) <= t.mv_max_move + 1e-9)
        active += np.any(np.isclose(np.abs(u - u_prev), t.mv_max_move)) or \
            np.any(np.isclose(u, t.mv_min)) or np.any(np.isclose(u, t.mv_max))
    assert active > 20  # the limits did bind: the comparison covered constrained steps


def test_clipped_moves_equal_numpy_dmc_with_clipping():
    """clip_moves: the QP plans without move limits and the first move is clipped (a DMC with
    move clipping), against the NumPy reference doing the same; the limits bind often and the
    inputs differ from the move-constrained MPC's."""
    t = tuning(mv_min=(9.6, 19.5), mv_max=(10.4, 20.3), max_move=(0.05, 0.08), clip_moves=True)
    mpc, ref = _core.Mpc(core_model(), t, U0), reference(t)
    constrained = _core.Mpc(core_model(), tuning(mv_min=(9.6, 19.5), mv_max=(10.4, 20.3), max_move=(0.05, 0.08)), U0)
    clipped, differ = 0, 0
    for y in measurements(150, 2.0, seed=2):
        u_prev = mpc.u.copy()
        u = mpc.step(y)
        u_ref = ref.step(y, clip=True)
        assert np.allclose(u, u_ref, rtol=0, atol=1e-7), (u, u_ref)
        assert np.all(np.abs(u - u_prev) <= t.mv_max_move + 1e-12)
        clipped += np.any(np.isclose(np.abs(u - u_prev), t.mv_max_move))
        differ += not np.allclose(u, constrained.step(y), atol=1e-6)
    assert clipped > 20 and differ > 20
    assert mpc.A.shape[0] < constrained.A.shape[0]  # the QP holds no move-limit rows


def osqp_form_to_quadprog(P, q, A, l, u):
    """min 1/2 x'Px + q'x, l <= Ax <= u  ->  quadprog's C'x >= b with equalities first."""
    P, q, A, l, u = (np.array(v, dtype=float) for v in (P, q, A, l, u))
    eq = np.isfinite(l) & np.isfinite(u) & (l == u)
    rows = [A[eq]] + [A[~eq & np.isfinite(l)], -A[~eq & np.isfinite(u)]]
    rhs = [l[eq], l[~eq & np.isfinite(l)], -u[~eq & np.isfinite(u)]]
    return quadprog.solve_qp(P, -q, np.vstack(rows).T, np.concatenate(rhs), int(eq.sum()))[0]


def test_soft_limits_qp_equals_quadprog_and_means_what_it_says():
    t = tuning(mv_min=(0, 0), mv_max=(30, 30), max_move=(0.3, 0.3),
               cv_min=[0.5, -INF], cv_max=[1.5, -1.0], cv_max_move=[0.02, INF],
               mv_soft_min=[9.8, -INF], mv_soft_max=[10.2, INF], cv_minmax_weight=[5.0, 1.0],
               mv_minmax_weight=[2.0, 1.0])
    mpc = _core.Mpc(core_model(), t, U0)
    nz = mpc.num_variables
    assert nz == 2 * 3 + 4  # du over Hc plus slacks: MV1 soft, CV1 and CV2 limits, CV1 movement
    theta = mpc.dynamic_matrix
    for y in measurements(60, 1.0, seed=3):
        u_prev = mpc.u.copy()
        mpc.step(y)
        x_ref = osqp_form_to_quadprog(mpc.P, mpc.q, mpc.A, mpc.l, mpc.u_bound)
        assert np.allclose(mpc.x, x_ref, rtol=0, atol=1e-7)
        du, s = x_ref[:6], x_ref[6:]
        forecast = mpc.free_response + theta @ du
        u_future = u_prev + np.cumsum(du.reshape(3, 2), axis=0)
        # each slack is the largest violation of its soft limit
        assert s[0] == pytest.approx(max(0, np.max(u_future[:, 0] - 10.2), np.max(9.8 - u_future[:, 0])), abs=1e-7)
        assert s[1] == pytest.approx(max(0, np.max(forecast[:8] - 1.5), np.max(0.5 - forecast[:8])), abs=1e-7)
        assert s[2] == pytest.approx(max(0, np.max(forecast[8:] + 1.0)), abs=1e-7)
        moves = np.diff(np.concatenate([[0.0], theta[:8] @ du]))
        assert s[3] == pytest.approx(max(0, np.max(np.abs(moves)) - 0.02), abs=1e-7)


def test_delay_beyond_horizon_is_measured_from_smallest_delay():
    import mpmpp.scenarios as scen
    from mpmpp.scenario import parse_scenario
    sc = parse_scenario(scen.paper_mimo())
    mpc = _core.Mpc(sc.model, sc.tuning, sc.tuning.mv_target)
    assert list(mpc.prediction_start) == [15, 19, 7]
    theta, hp = mpc.dynamic_matrix, 20
    steam4 = theta[hp:2 * hp, 1::3]  # press_moisture rows, steam_4 columns: G22 (delay 23) is seen
    assert np.count_nonzero(steam4) > 0 and np.all(steam4[:23 - 19, 0] == 0)


@pytest.mark.parametrize("field, value, message", [
    ("move_weight", [0.0, 0.1], "move_weight[0] must be > 0"),
    ("cv_target", [1.0], "cv_target must have 2 entries"),
    ("mv_max_move", [0.0, 1.0], "mv_max_move[0] must be > 0"),
    ("cv_target_weight", [-1.0, 1.0], "cv_target_weight[0] must be >= 0"),
    ("control_horizon", 9, "control_horizon must be in [1, prediction_horizon]"),
])
def test_bad_tuning_is_a_value_error_naming_the_field(field, value, message):
    t = tuning()
    setattr(t, field, value)
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        _core.Mpc(core_model(), t, U0)


def test_model_channel_must_be_strictly_proper():
    model = core_model({"y1": {"u1": TF([0.5], [1, -0.8], 3)}, "y2": {"u2": TF([0.4], [1.0, -0.5], 0)}})
    with pytest.raises(ValueError, match="strictly proper"):
        _core.Mpc(model, tuning(), U0)


def test_initial_input_outside_bounds_is_rejected():
    with pytest.raises(ValueError, match="outside"):
        _core.Mpc(core_model(), tuning(mv_min=(11, 0), mv_max=(12, 30)), U0)
