"""compare's hysteresis check (hysteresis_test.py): its regressors against a plain Python play
operator filtered by SciPy, its statistic against plain least squares, its null distribution on
linear PI loops with the exact model (chi-square), and a sticking valve that the linear residual
tests miss."""
import numpy as np
import pandas as pd
import pytest
from scipy.signal import lfilter
from scipy.stats import chi2

import mpmpp
from mpmpp import hysteresis_test as ht
from mpmpp._core import ActuatorNonlinearity
from mpmpp.compare import compare
from mpmpp.identify import model_from_data
from mpmpp.record_length import MIN_ROWS
from mpmpp.signals import extract
from mpmpp.stiction.loop import coloured_noise, simulate_pi_loop

import pi_loop
import stiction_benchmark as sb


def _play(x, width):
    """Prandtl's play operator at rest at x[0], written from its definition."""
    p, out = x[0], []
    for v in x:
        p = min(max(p, v - width / 2), v + width / 2)
        out.append(p)
    return np.array(out)


def _open_loop(delay, n=1500, seed=4):
    rng = np.random.default_rng(seed)
    u = 40.0 + np.cumsum(rng.standard_normal(n))
    y = rng.standard_normal(n)
    model = mpmpp.Model("t", 5.0, ["u"], ["y"],
                        process={"y": {"u": mpmpp.TransferFunction([0.2, 0.1], [1.0, -0.7], delay)}},
                        noise={"y": mpmpp.TransferFunction([1.0, -0.3], [1.0, -0.9])})
    return model, pd.DataFrame({"time": 5.0 * np.arange(n), "u": u, "y": y})


@pytest.mark.parametrize("delay", [2, 0])
def test_direction_is_the_play_through_the_model_and_its_noise_inverse(delay):
    model, data = _open_loop(delay)
    sig = extract(model, data, min_segment=MIN_ROWS)
    u = data["u"].to_numpy()
    moved = _play(u, 1.5) - u
    ref = lfilter([1.0, -0.9], [1.0, -0.3], lfilter(np.r_[np.zeros(delay), 0.2, 0.1], [1.0, -0.7], moved))
    z = ht._play_directions(sig, 0, 0, [1.5])[:, 0]
    if delay == 0:   # a lag-0 channel's direction is taken one sample later
        assert np.isnan(z[0])
        ref = np.r_[np.nan, ref[:-1]]
    np.testing.assert_allclose(z[1:], ref[1:], atol=1e-10)


def test_statistic_is_the_nested_least_squares_drop():
    """The Gram-matrix shortcut against plain least squares on the design itself: a level, the error's
    own lags and the whitened Laguerre basis, then the plays."""
    model, data = _open_loop(2)
    sig = extract(model, data, min_segment=MIN_ROWS)
    e = np.random.default_rng(9).standard_normal(len(data))
    check = ht.hysteresis_check(sig, 0, 0, e, np.ones(len(data), bool))
    z = ht._play_directions(sig, 0, 0, np.std(sig.u[:, 0]) * np.asarray(ht.WIDTHS))
    rows = np.arange(ht.ERROR_LAGS, len(e))
    lin = np.column_stack([np.ones(len(rows)), e[rows[:, None] - np.arange(1, ht.ERROR_LAGS + 1)],
                           ht._linear_change_basis(sig, 0, 0)[rows]])
    full = np.column_stack([lin, z[rows]])

    def rss(a):
        return np.sum((e[rows] - a @ np.linalg.lstsq(a, e[rows], rcond=None)[0]) ** 2)

    assert check.statistic == pytest.approx(len(rows) * (rss(lin) - rss(full)) / rss(full), rel=1e-6)
    assert check.explained == pytest.approx((rss(lin) - rss(full)) / rss(lin), rel=1e-6)
    assert check.significant == (check.statistic > chi2.isf(ht.SIGNIFICANCE, len(ht.WIDTHS))
                                 and check.explained >= ht.MIN_SHARE)


def _exact_model(loop, ts=10.0):
    a, b0, b1, d = pi_loop.foptd_coefficients(loop, ts)
    return mpmpp.Model("exact", ts, ["OP"], ["PV"],
                       process={"PV": {"OP": mpmpp.TransferFunction([b0, b1], [1.0, -a], d)}},
                       noise={"PV": mpmpp.TransferFunction([1.0], [1.0, -loop.noise_pole])})


def test_a_linear_loop_with_its_exact_model_gives_the_chi_square_statistic():
    """Linear valves, the exact model, 2 h at 10 s (the plain NumPy loop simulator): the statistic
    follows chi-square(len(WIDTHS)) (mean 5; the finite-sample factor N / (N - 55) adds ~8 %),
    and at the 1e-3 level at most one of 30 records is flagged (P(>= 2) = 4e-4)."""
    stats = []
    for loop in (pi_loop.FLOW, pi_loop.LEVEL, pi_loop.PRESSURE):
        for seed in range(10):
            out = compare(_exact_model(loop), pi_loop.simulate(loop, 300 + seed, setpoint_steps=seed % 2 == 1))
            stats.append(out.outputs[0].hysteresis[0].statistic)
    stats = np.array(stats)
    assert 3.5 < stats.mean() < 7.5
    assert np.sum(stats > chi2.isf(ht.SIGNIFICANCE, len(ht.WIDTHS))) <= 1


def _flow_loop(seed, valve=None):
    rng = np.random.default_rng(seed)
    d = coloured_noise(rng, 751, 0.3, 0.8) + 0.05 * rng.standard_normal(751)
    sp = np.where(np.arange(751) // 120 % 2 == 1, 2.0, 0.0)   # setpoint steps every 20 min
    flow = sb.TUNING[0]
    rec = simulate_pi_loop(flow.process, flow.kc, flow.ti, 751, valve=valve, disturbance=d, setpoint=sp)
    return pd.DataFrame({"time": 10.0 * np.arange(751), "OP": rec["op"], "PV": rec["pv"] + 20.0})


@pytest.mark.parametrize("seed", [21, 22, 23])
def test_a_sticking_valve_is_flagged_where_the_linear_attribution_is_not(seed):
    """A flow loop with setpoint steps whose valve sticks (stick-slip, S = 3 % OP, J = 1.5), with
    the model ``identify`` fits on the record (as a user without a model gets): the hysteresis
    check flags the OP, with a play between S - J and S wide, where the OP's linear lags explain
    nothing significant (the identified model holds the linear part); the same loop with a linear
    valve is not flagged."""
    sticky = _flow_loop(seed, ActuatorNonlinearity(stiction_s=3.0, stiction_j=1.5))
    res = compare(model_from_data(sticky, ["OP"], ["PV"]).model, sticky)
    check = res.outputs[0].hysteresis[0]
    assert check.significant and check.column == "OP"
    assert 1.2 < check.width < 4.0
    assert not res.outputs[0].attribution[0].significant
    assert "play (backlash)" in res.summary()
    assert res.to_dict()["outputs"][0]["hysteresis"][0]["significant"] is True   # compare --json
    linear = _flow_loop(seed)
    assert not compare(model_from_data(linear, ["OP"], ["PV"]).model, linear).outputs[0].hysteresis[0].significant
