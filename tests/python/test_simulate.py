"""Closed-loop simulator: against a NumPy closed loop, SciPy filtering of the recorded
signals (plant, events, noise), NumPy actuator rules, and the paper's scenarios' limits
and stability."""

import numpy as np
import pytest
from scipy.signal import lfilter

import mpmpp
from mpmpp import _core, scenarios
from mpmpp.scenario import parse_scenario
from mpmpp.simulate import run
from reference_mpc import NumpyMpc, closed_loop, full_numerator


def tf_filter(spec, x):
    return lfilter(full_numerator(spec["num"], spec.get("delay", 0)), spec["den"], x)


def shifted(x):
    """x(t-1) with x(-1) = 0: the plant forms y(t) from inputs up to t-1."""
    return np.concatenate([np.zeros((1,) + x.shape[1:]), x[:-1]])


@pytest.fixture(scope="module")
def siso_data():
    return mpmpp.simulate(scenarios.paper_siso())


@pytest.fixture(scope="module")
def mimo_data():
    return mpmpp.simulate(scenarios.paper_mimo())


def test_noise_free_siso_loop_equals_numpy_closed_loop():
    spec = scenarios.paper_siso()
    sc = parse_scenario(spec)
    cfg = sc.to_config()
    plant = cfg.plant
    truth = ([0.1003 * 1.5], [1.0, -0.9048], 17)  # a plant/model mismatch
    plant.process = [[_core.TransferFunction(*truth)]]
    plant.sigma = [0.0]
    cfg.plant = plant
    cfg.y_operating = [24.25]  # start 0.5 off target: the move limit binds at first
    cfg.events = []
    cfg.num_samples = 600
    res = _core.simulate_closed_loop(cfg)
    t = sc.tuning
    ref = NumpyMpc([[([0.1003], [1.0, -0.9048], 17)]], 40, 4, t.cv_target, t.mv_target, t.cv_target_weight,
                   t.mv_target_weight, t.move_weight, t.deviation_weight, t.mv_min, t.mv_max, t.mv_max_move,
                   t.mv_target)
    U, Y = closed_loop(None, [[truth]], [([1.0], [1.0], 0)], [0.0], [24.25], 0, 600, ref)
    assert np.allclose(res.u, U, rtol=0, atol=1e-7)
    assert np.allclose(res.y, Y, rtol=0, atol=1e-7)
    assert np.isclose(np.abs(np.diff(U[:40, 0])).max(), 0.1667)  # constrained steps were compared
    assert abs(Y[-1, 0] - 23.75) < 1e-3  # offset-free despite the 1.5x gain error


def test_plant_events_extra_channel_and_drift_match_scipy():
    spec = scenarios.paper_siso()
    g_old = spec["process"]["dry_weight"]["stock_flow"]
    g_new = {"num": [0.15], "den": [1.0, -0.8], "delay": 20}
    x_tf = {"num": [0.0, 0.5], "den": [1.0, -0.6], "delay": 3}
    spec["truth"] = {"sigma": {"dry_weight": 0.0},
                     "extra": {"consistency": {"operating_point": 1.1, "sigma": 0.3,
                                               "noise": {"num": [1.0], "den": [1.0, -0.9]}}}}
    spec["duration_s"] = 2000 * 5.0
    spec["events"] = [
        {"time_s": 400 * 5.0, "type": "extra_channel", "output": "dry_weight", "extra": "consistency", "model": x_tf},
        {"time_s": 800 * 5.0, "type": "process", "output": "dry_weight", "input": "stock_flow", "model": g_new},
        {"time_s": 1200 * 5.0, "type": "drift", "output": "dry_weight", "offset": 0.2, "rate_per_s": 0.001},
    ]
    res = run(spec)
    u_dev = res.u_actual[:, 0] - 131.0
    x_dev = res.extra[:, 0] - 1.1
    n = np.arange(2000)
    expected = 23.75 + np.where(n < 800, tf_filter(g_old, u_dev), tf_filter(g_new, u_dev))
    expected += np.where(n >= 400, tf_filter(x_tf, x_dev), 0.0)
    expected += np.where(n >= 1200, 0.2 + 0.005 * (n - 1200), 0.0)
    assert np.allclose(res.y[:, 0], expected, rtol=0, atol=1e-9)
    # the extra variable is x0 + H sigma e: whitened by 1/H its innovations have std sigma
    e = lfilter([1.0, -0.9], [1.0], x_dev)
    assert abs(e.std() / 0.3 - 1) < 0.06 and abs(np.corrcoef(e[1:], e[:-1])[0, 1]) < 0.08


def test_noise_is_box_jenkins_and_noise_events_switch_h(siso_data):
    # Before the gain change the model is exact, so v = y - y0 - G0 u is H0 sigma e.
    spec = scenarios.paper_siso()
    res = run(spec)
    g = spec["process"]["dry_weight"]["stock_flow"]
    v = res.y[:, 0] - 23.75 - tf_filter(g, shifted(res.u_actual[:, 0] - 131.0))
    h_old, h_new = spec["noise"]["dry_weight"], spec["events"][0]["model"]
    for h, a, b in ((h_old, 0, 5040), (h_new, 5040, 7920)):
        e = lfilter(h["den"], h["num"], v[:b])[a + 50:b]  # whiten with the H in force
        assert abs(e.std() / 0.05 - 1) < 0.05
        assert abs(np.corrcoef(e[1:], e[:-1])[0, 1]) < 0.06
    assert np.array_equal(siso_data["dry_weight"].values, res.y[:, 0])


def test_sigma_event_scales_the_noise():
    spec = scenarios.paper_siso()
    spec["duration_s"] = 4000 * 5.0
    spec["events"] = [{"time_s": 2000 * 5.0, "type": "sigma", "output": "dry_weight", "value": 0.15}]
    y = mpmpp.simulate(spec)["dry_weight"].values
    assert 2.5 < y[2200:].std() / y[200:2000].std() < 3.5


def numpy_actuator(cmd, u0, rules):
    """rules: [(start sample, deadband, backlash, lo, hi)]; state carries across rule changes."""
    stuck = play = u0
    out = []
    for t, c in enumerate(cmd):
        _, deadband, backlash, lo, hi = [r for r in rules if r[0] <= t][-1]
        if abs(c - stuck) > deadband:
            stuck = c
        if stuck > play + backlash / 2:
            play = stuck - backlash / 2
        elif stuck < play - backlash / 2:
            play = stuck + backlash / 2
        out.append(min(max(play, lo), hi))
    return np.array(out)


def test_actuator_nonlinearity_follows_its_rules():
    spec = scenarios.paper_siso()
    spec["duration_s"] = 3000 * 5.0
    spec["truth"]["actuators"] = {"stock_flow": {"backlash": 0.1}}
    spec["events"] = [{"time_s": 1000 * 5.0, "type": "actuator", "input": "stock_flow",
                       "deadband": 0.08, "backlash": 0.05, "min": 130.9, "max": 131.2}]
    res = run(spec)
    cmd, pos = res.u[:, 0], res.u_actual[:, 0]
    expected = numpy_actuator(cmd, 131.0, [(0, 0.0, 0.1, -np.inf, np.inf), (1000, 0.08, 0.05, 130.9, 131.2)])
    assert np.array_equal(pos, expected)
    assert np.mean(pos != cmd) > 0.3  # the nonlinearity did act


def check_limits(df, spec):
    for name, mv in spec["controller"]["mv"].items():
        u = df[name].values
        assert u.min() >= mv["min"] - 1e-9 and u.max() <= mv["max"] + 1e-9, name
        moves = np.abs(np.diff(np.concatenate([[mv["target"]], u])))
        assert moves.max() <= mv["max_move"] + 1e-9, name


def test_siso_mv_limits_never_violated(siso_data):
    check_limits(siso_data, scenarios.paper_siso())
    assert siso_data.attrs["failed_solves"] == 0


def test_mimo_mv_limits_never_violated(mimo_data):
    check_limits(mimo_data, scenarios.paper_mimo())
    assert mimo_data.attrs["failed_solves"] == 0


def check_stable_after_events(df, spec):
    ts = spec["sample_time_s"]
    bounds = [0] + [int(e["time_s"] / ts) for e in spec["events"]] + [len(df)]
    for out in spec["outputs"]:
        y = df[out].values
        before = y[200:bounds[1]].std()
        for a, b in zip(bounds[1:-1], bounds[2:]):
            seg = y[a + 200:b]
            half = len(seg) // 2
            assert seg.std() < 5 * before, (out, a)               # bounded vs before the changes
            assert seg[half:].std() < 1.6 * seg[:half].std(), (out, a)  # not growing


def test_siso_stable_after_every_change(siso_data):
    check_stable_after_events(siso_data, scenarios.paper_siso())


def test_mimo_stable_after_every_change(mimo_data):
    check_stable_after_events(mimo_data, scenarios.paper_mimo())


def test_data_columns_follow_formats(mimo_data):
    spec = scenarios.paper_mimo()
    assert list(mimo_data.columns) == ["time"] + spec["inputs"] + spec["outputs"] + \
        [f"{o}_sp" for o in spec["outputs"]]
    assert len(mimo_data) == 20700 and np.allclose(np.diff(mimo_data["time"]), 5.0)
    assert np.all(mimo_data["press_dry_weight_sp"] == 174.0)


def test_same_seed_same_data_other_seed_other_data():
    spec = scenarios.paper_siso()
    spec["duration_s"] = 500 * 5.0
    spec["events"] = []
    a, b = mpmpp.simulate(spec, seed=7), mpmpp.simulate(spec, seed=7)
    c = mpmpp.simulate(spec, seed=8)
    assert a.equals(b)
    assert not np.allclose(a["dry_weight"], c["dry_weight"])
    spec["seed"] = 7
    assert mpmpp.simulate(spec).equals(a)


def test_setpoint_event_moves_the_cv():
    spec = scenarios.paper_siso()
    spec["duration_s"] = 1500 * 5.0
    spec["truth"]["sigma"]["dry_weight"] = 0.0
    spec["events"] = [{"time_s": 100 * 5.0, "type": "setpoint", "output": "dry_weight", "value": 24.0}]
    df = mpmpp.simulate(spec)
    assert df["dry_weight_sp"].iloc[99] == 23.75 and df["dry_weight_sp"].iloc[100] == 24.0
    assert abs(df["dry_weight"].iloc[-1] - 24.0) < 1e-6
