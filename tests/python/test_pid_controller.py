"""Multi-loop PID (cpp/src/pid_controller.cpp) against a plain NumPy implementation of the
velocity-form equations in pid_controller.hpp, and in closed loop on a first-order plant."""
import numpy as np
import pytest

import mpmpp
from mpmpp import _core


def loop(output, input, gain, ti=np.inf, td=0.0, n=10.0, lo=-np.inf, hi=np.inf):
    p = _core.PidLoop()
    p.output, p.input, p.gain, p.integral_time_s = output, input, gain, ti
    p.derivative_time_s, p.derivative_filter, p.min, p.max = td, n, lo, hi
    return p


def numpy_pid(loops, ts, u0, y, r):
    """Positional bookkeeping of the same law: e, filtered derivative on -y, du, clip."""
    u = np.array(u0, float)
    out = np.empty((len(y), len(u)))
    state = {id(l): dict(e=r[0, l[0]] - y[0, l[0]], y=y[0, l[0]], d=0.0) for l in loops}
    for t in range(len(y)):
        for l in loops:
            i, j, k, ti, td, n, lo, hi = l
            st = state[id(l)]
            e = r[t, i] - y[t, i]
            d = st["d"]
            if td > 0:
                tf = td / n
                d = tf / (tf + ts) * st["d"] - td / (tf + ts) * (y[t, i] - st["y"])
            du = k * ((e - st["e"]) + ts / ti * e + (d - st["d"]))
            u[j] = np.clip(u[j] + du, lo, hi)
            st.update(e=e, y=y[t, i], d=d)
        out[t] = u
    return out


@pytest.mark.parametrize("seed", range(3))
def test_matches_numpy(seed):
    rng = np.random.default_rng(seed)
    n, ts = 800, 5.0
    y = rng.normal(0, 1, (n, 2)).cumsum(axis=0) * 0.1
    r = np.zeros((n, 2))
    r[300:, 0], r[500:, 1] = 1.5, -2.0
    specs = [(0, 1, 0.8, 60.0, 10.0, 8.0, -3.0, 3.0), (1, 0, -1.2, 120.0, 0.0, 10.0, -np.inf, np.inf)]
    loops = [loop(*s) for s in specs]
    got = _core.pid_outputs(loops, ts, np.zeros(2), y, r)
    np.testing.assert_allclose(got, numpy_pid(specs, ts, np.zeros(2), y, r), atol=1e-12)
    assert np.any(np.abs(got[:, 1]) == 3.0)  # the saturation did bind


def pi_scenario():
    plant = {"num": [0.2], "den": [1.0, -0.9], "delay": 3}
    return {"sample_time_s": 1.0, "inputs": ["u"], "outputs": ["y"], "process": {"y": {"u": plant}},
            "truth": {"sigma": {"y": 0.0}},
            "controller": {"kind": "pid", "cv": {"y": {"target": 10.0}}, "mv": {"u": {"target": 50.0}},
                           "loops": [{"cv": "y", "mv": "u", "gain": 0.8, "integral_time_s": 8.0,
                                      "min": 40.0, "max": 70.0}]},
            "duration_s": 600.0, "events": [{"time_s": 100.0, "type": "setpoint", "output": "y", "value": 12.0}]}


def test_pi_in_closed_loop_removes_the_offset():
    """y(t) = 0.2 / (1 - 0.9 q^-1) q^-3 u: integral action brings y to the new setpoint, and the
    recorded commands are the controller's law applied to the recorded y (same C++ law, the
    loop closed by the simulator)."""
    df = mpmpp.simulate(pi_scenario())
    assert abs(df["y"].iloc[-1] - 12.0) < 1e-3 and abs(df["y"].iloc[99] - 10.0) < 1e-12
    u = numpy_pid([(0, 0, 0.8, 8.0, 0.0, 10.0, 40.0, 70.0)], 1.0, [50.0], df[["y"]].to_numpy(),
                  df[["y_sp"]].to_numpy())
    np.testing.assert_allclose(df["u"].to_numpy(), u[:, 0], atol=1e-9)


def test_pid_scenario_errors():
    spec = pi_scenario()
    spec["controller"]["loops"].append(dict(spec["controller"]["loops"][0]))
    with pytest.raises(ValueError, match=r"controller.loops\[1\].cv: is already in another loop"):
        mpmpp.simulate(spec)
    spec = pi_scenario()
    spec["events"].append({"time_s": 5.0, "type": "mv_target", "input": "u", "value": 1.0})
    with pytest.raises(ValueError, match="mv_target events need the MPC"):
        mpmpp.simulate(spec)
    spec = pi_scenario()
    spec["controller"]["loops"][0]["gain"] = 0
    with pytest.raises(ValueError, match=r"controller.loops\[0\].gain: must be non-zero"):
        mpmpp.simulate(spec)


@pytest.mark.parametrize("loops, message", [
    ([loop(0, 0, 0.0)], "gain must be finite and non-zero"),
    ([loop(0, 0, 1.0), loop(0, 1, 1.0)], "one loop only"),
    ([loop(0, 0, 1.0, lo=1.0, hi=2.0)], "initial input"),
    ([loop(3, 0, 1.0)], "output index")])
def test_bad_loops(loops, message):
    with pytest.raises(ValueError, match=message):
        _core.pid_outputs(loops, 1.0, np.zeros(2), np.zeros((3, 2)), np.zeros((3, 2)))
