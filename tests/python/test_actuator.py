"""The actuator model (cpp/src/actuator.cpp) against a plain NumPy implementation of the same
equations: Choudhury et al.'s or He et al.'s two-parameter stiction (S, J), deadband, backlash,
saturation."""
import numpy as np
import pytest
from valve_reference import he_reference

from mpmpp import _core


def numpy_stiction(x, s, j, u0):
    """Choudhury, Thornhill and Shah (2005), data-driven stiction model, as a flow of cases."""
    y = np.empty_like(x)
    prev_x, prev_y = u0, u0
    moving, v_old = False, 0.0
    x_ss, dir_ss = u0, 0.0
    for k, xk in enumerate(x):
        v = np.sign(xk - prev_x)
        if moving and v != v_old:   # stop or reversal: stick at the last command
            moving, x_ss, dir_ss = False, prev_x, v_old
        if moving:
            out = xk - v * (s - j) / 2
        else:
            travel = xk - x_ss
            threshold = j if np.sign(travel) == dir_ss else s
            if v != 0 and np.sign(travel) == v and abs(travel) > threshold:
                moving, out = True, xk - v * (s - j) / 2
            else:
                out = prev_y
        if moving:
            v_old = v
        y[k], prev_x, prev_y = out, xk, out
    return y


def numpy_actuator(x, u0, s=0.0, j=0.0, deadband=0.0, backlash=0.0, lo=-np.inf, hi=np.inf,
                   law="choudhury"):
    if law == "he":   # fs = (S + J)/2, fd = (S - J)/2; the reference starts at its first input
        stick = he_reference(np.r_[u0, x], (s + j) / 2, (s - j) / 2)[1:]
    else:
        stick = numpy_stiction(x, s, j, u0)
    held, play, out = u0, u0, []
    for c in stick:
        if abs(c - held) > deadband:
            held = c
        play = min(max(play, held - backlash / 2), held + backlash / 2)
        out.append(np.clip(play, lo, hi))
    return np.array(out)


def nonlinearity(**kw):
    a = _core.ActuatorNonlinearity()
    for k, v in kw.items():
        setattr(a, k, v)
    return a


def commands(seed, n=3000):
    """A command with random-walk stretches, pauses (held values) and reversals."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(0, 0.3, n) * (rng.uniform(size=n) > 0.3)
    return 50 + np.cumsum(steps)


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("params", [
    dict(stiction_s=1.0, stiction_j=0.0), dict(stiction_s=1.0, stiction_j=0.5),
    dict(stiction_s=2.0, stiction_j=2.0), dict(deadband=0.7), dict(backlash=0.8),
    dict(min=49.0, max=52.0), dict(stiction_s=1.5, stiction_j=0.4, backlash=0.3, min=45.0, max=55.0),
    dict(stiction_law="he", stiction_s=1.5, stiction_j=0.5),
    dict(stiction_law="he", stiction_s=1.0, stiction_j=0.0, deadband=0.2, max=52.0)])
def test_matches_numpy(seed, params):
    x = commands(seed)
    ref = numpy_actuator(x, 50.0, params.get("stiction_s", 0.0), params.get("stiction_j", 0.0),
                         params.get("deadband", 0.0), params.get("backlash", 0.0),
                         params.get("min", -np.inf), params.get("max", np.inf),
                         params.get("stiction_law", "choudhury"))
    if "stiction_law" in params:
        params = dict(params, stiction_law=getattr(_core.StictionLaw, params["stiction_law"]))
    got = _core.actuator_positions(x, nonlinearity(**params), 50.0)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    assert np.mean(got != x) > 0.1  # the nonlinearity did act


def test_stiction_analytic_ramp_and_reversal():
    """From rest, a ramp moves the valve only once it has travelled more than S, then it jumps
    to x - (S - J)/2 and follows; after a reversal it sticks again for S of travel."""
    s, j = 2.0, 0.5
    up = np.arange(1, 41) * 0.1          # 0.1 .. 4.0
    down = 4.0 - np.arange(1, 41) * 0.1  # 3.9 .. 0.0
    y = _core.actuator_positions(np.concatenate([up, down]), nonlinearity(stiction_s=s, stiction_j=j), 0.0)
    first = np.argmax(y[:40] != 0.0)
    assert up[first] > s and up[first - 1] <= s + 1e-12
    np.testing.assert_allclose(y[first:40], up[first:] - (s - j) / 2)
    # after the reversal at 4.0 the valve holds 4.0 - 0.75 until the command is S below 4.0
    held = y[40:]
    moved = np.argmax(held != held[0])
    assert held[0] == pytest.approx(4.0 - (s - j) / 2)
    assert 4.0 - down[moved] > s and 4.0 - down[moved - 1] <= s + 1e-12
    np.testing.assert_allclose(held[moved:], down[moved:] + (s - j) / 2)


def test_stepping_is_the_sequence():
    x = commands(5)
    nl = nonlinearity(stiction_law=_core.StictionLaw.he, stiction_s=1.2, stiction_j=0.3, backlash=0.2)
    a = _core.Actuator(nl, 50.0)
    np.testing.assert_array_equal([a.move(c) for c in x], _core.actuator_positions(x, nl, 50.0))
    with pytest.raises(ValueError, match="command must be finite"):
        a.move(np.nan)


def test_no_stiction_is_the_identity():
    x = commands(9)
    np.testing.assert_array_equal(_core.actuator_positions(x, nonlinearity(), 50.0), x)


@pytest.mark.parametrize("params, message", [
    (dict(stiction_s=1.0, stiction_j=2.0), "J must be <= S"),
    (dict(stiction_s=-1.0), "stiction S must be"),
    (dict(min=2.0, max=1.0), "min must be <= max")])
def test_bad_parameters(params, message):
    with pytest.raises(ValueError, match=message):
        _core.actuator_positions(np.zeros(3), nonlinearity(**params), 0.0)
