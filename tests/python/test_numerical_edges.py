"""Numerical edge cases: each gives a flagged result or a clear error, never a confident
wrong answer. References are analytic (pole 0.999: 1% settling at ceil(ln 0.01 / ln 0.999)
samples) or NumPy least squares written here."""
import copy
import math

import numpy as np
import pytest

import mpmpp
from mpmpp import identify, scenarios

TF = mpmpp.TransferFunction


def siso_data(n, seed, g=None, sigma=0.05):
    g = g if g is not None else TF([0.5, 0.25], [1.0, -0.6], 2)
    rng = np.random.default_rng(seed)
    u = rng.normal(size=n)
    return g.filter(u) + sigma * rng.normal(size=n), u


def test_ill_conditioned_arx_is_regularised_or_refused():
    """Two inputs that differ by 1e-9 of their size: the ARX normal equations are singular
    to working precision. Either the Section 3.1 ridge is applied (and says so) or the
    window is refused as collinear; an unregularised confident estimate would be wrong."""
    y, u1 = siso_data(600, 1)
    u = np.column_stack([u1, u1 + 1e-9 * np.random.default_rng(2).normal(size=600)])
    try:
        r = identify.arx(y, u, 2, [2, 2], [2, 2])
    except RuntimeError as exc:
        assert "collinear" in str(exc) or "not informative" in str(exc)
        return
    assert r.regularised, "near-singular regression solved without regularisation"
    assert np.all(np.isfinite(r.theta))
    # The identifiable combination (the sum of the two inputs' coefficients) is still right:
    # compare with NumPy least squares on the single input.
    single = identify.arx(y, u1, 2, 2, 2)
    b_sum = np.asarray(r.b[0]) + np.asarray(r.b[1])
    np.testing.assert_allclose(b_sum, single.b[0], atol=0.05)


def test_badly_scaled_arx_matches_numpy_lstsq():
    """Inputs 1e8 times the outputs' size: the column scaling keeps the estimate exact."""
    y, u = siso_data(800, 3)
    r = identify.arx(y, u * 1e8, 1, 2, 2, delta=0.0)
    N = len(y)
    phi = np.column_stack([-y[2:N - 1], 1e8 * u[1:N - 2], 1e8 * u[0:N - 3]])
    theta, *_ = np.linalg.lstsq(phi, y[3:], rcond=None)
    np.testing.assert_allclose(r.theta, theta, rtol=1e-6)


def test_near_unstable_pole_0999():
    g = TF([0.001], [1.0, -0.999], 3)
    assert g.is_stable() and abs(g.dc_gain() - 1.0) < 1e-12
    # |g(k)| = 0.001 * 0.999^(k-3) for k >= 3: below 1% of the peak from k = 3 + ceil(ln .01/ln .999).
    expected = 3 + math.ceil(math.log(0.01) / math.log(0.999))
    assert identify.fir_length_to_one_percent(g) == expected
    # Identification on 4000 samples of a pole this slow: finite, pole inside the radius cap.
    rng = np.random.default_rng(4)
    u = np.repeat(rng.choice([-1.0, 1.0], size=40), 100)
    y = g.filter(u) + 0.001 * rng.normal(size=u.size)
    r = identify.arx_oe(y, u, 4, 4, 3, fir_length=200)
    c = r.channels[0]
    assert np.all(np.isfinite(c.fir)) and abs(c.f[1]) <= 0.9999
    assert abs(-c.f[1] - 0.999) < 0.01


def test_unstable_and_integrating_nominal_is_a_clear_error():
    for g in (TF([1.0], [1.0, -1.0]), TF([1.0], [1.0, -1.0001])):
        assert not g.is_stable()
        with pytest.raises(ValueError, match="does not fall below 1%"):
            identify.fir_length_to_one_percent(g)


def test_exact_zero_channel():
    """A channel whose true gain is exactly zero: ARX-OE gives a gain near zero for it while
    the real channel is found; a zero nominal cannot give a FIR length (clear error)."""
    rng = np.random.default_rng(5)
    u = rng.normal(size=(2000, 2))
    y = TF([0.5], [1.0, -0.7], 1).filter(u[:, 0]) + 0.05 * rng.normal(size=2000)
    r = identify.arx_oe(y, u, 4, 4, [1, 1], fir_length=40)
    assert abs(r.channels[0].gain - 0.5 / 0.3) < 0.1
    assert abs(r.channels[1].gain) < 0.05
    with pytest.raises(ValueError, match="zero"):
        identify.fir_length_to_one_percent(TF([0.0], [1.0]))
    # A model may hold an explicit zero channel; it round-trips and simulates as zero.
    m = mpmpp.Model("z", 1.0, ["u"], ["y"], {"y": {"u": TF([0.0], [1.0])}})
    assert mpmpp.Model.from_json(m.to_json()) == m
    assert np.all(m.process("y", "u").filter(np.ones(10)) == 0.0)


def test_constant_inputs_flag_every_window():
    y, u = siso_data(1000, 6)
    u[400:] = u[399]  # the input freezes
    windows = identify.arx_oe_windows(y, u, 200, 200, 2, 2, 2, fir_length=20)
    assert [w.ok for w in windows] == [True, True, False, False, False]
    assert all("u[0] is constant" in w.message for w in windows[2:])


def test_data_with_gaps(tmp_path):
    """NaN runs in a data file are counted on load and flag exactly the windows they touch."""
    y, u = siso_data(1200, 7)
    y[250:260] = np.nan          # a 10-sample gap in the second window
    u[900:1000] = np.nan         # a 100-sample gap across windows 4 and 5
    import pandas as pd
    path = tmp_path / "gaps.csv"
    mpmpp.save_data(path, pd.DataFrame({"time": np.arange(1200.0), "u": u, "y": y}))
    df = mpmpp.load_data(path)
    assert df.attrs["missing"] == {"u": 100, "y": 10}
    windows = identify.arx_oe_windows(df["y"].to_numpy(), df["u"].to_numpy(), 200, 200, 2, 2, 2,
                                      fir_length=20)
    assert [w.ok for w in windows] == [True, False, True, True, False, True]
    assert "y has 10 non-finite samples" in windows[1].message
    assert "u[0] has 100 non-finite samples" in windows[4].message


def saturated_siso(hours):
    """The paper's SISO loop asked for a dry weight the stock flow cannot reach: the MV sits
    on its upper limit for `hours`."""
    spec = copy.deepcopy(scenarios.paper_siso())
    spec["events"] = [{"time_s": 600.0, "type": "setpoint", "output": "dry_weight", "value": 40.0}]
    spec["controller"]["mv"]["stock_flow"]["max"] = 132.0
    spec["duration_s"] = hours * scenarios.HOUR
    return spec


def test_saturated_actuator_for_hours():
    hours = 3
    df = mpmpp.simulate(saturated_siso(hours), seed=1)
    u, y = df["stock_flow"].to_numpy(), df["dry_weight"].to_numpy()
    assert len(df) == hours * 3600 / 5 and np.all(np.isfinite(u)) and np.all(np.isfinite(y))
    assert df.attrs["failed_solves"] == 0
    pinned = np.flatnonzero(u >= 132.0 - 1e-9)
    assert pinned.size and np.all(u[pinned[0]:] <= 132.0 + 1e-9)
    assert np.all(u[pinned[0]:] == 132.0), "the MV left its bound although the target is unreachable"
    # Identification on the saturated stretch: every window is flagged (constant input).
    start = pinned[0]
    windows = identify.arx_oe_windows(y[start:], u[start:], 720, 720, 9, 10, 17, fir_length=60)
    assert windows and not any(w.ok for w in windows)
    assert all("constant" in w.message for w in windows)
