"""ARX, OE and the ARX-OE pipeline against the independent NumPy/SciPy implementation
in identification_reference.py (same equations, explicit matrices, lstsq, least_squares)."""
import numpy as np
import pytest
import scipy.signal as ss

import identification_reference as ref
from mpmpp import identify

# The paper's SISO example (Section 5.1): G0 = 0.1003 q^-17 / (1 - 0.9048 q^-1).
G0 = ([0.1003], [1.0, -0.9048], 17)
H0 = ([1.0, -0.3], [1.0, 0.6])


def open_loop(N, seed, channels, noise=0.05):
    """MISO open-loop data: u white, y = sum_j q^-d_j b_j/f_j u_j + H0 e."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((N, len(channels)))
    y = ss.lfilter(*H0, noise * rng.standard_normal(N))
    for j, (b, f, d) in enumerate(channels):
        y += ss.lfilter(np.r_[np.zeros(d), b], f, u[:, j])
    return y, u


@pytest.fixture(scope="module")
def siso_closed_loop():
    y, u = ref.closed_loop(N=1440, seeds=[3], **ref.PAPER_SISO)
    return y[0, :, 0], u[0, :, 0]


def test_arx_siso_equals_lstsq(siso_closed_loop):
    y, u = siso_closed_loop
    r = identify.arx(y, u, 9, 10, 17)
    theta, sigma2, regularised = ref.arx(y, u[:, None], 9, [10], [17], delta=1e-4)
    assert not r.regularised and not regularised
    np.testing.assert_allclose(r.theta, theta, rtol=1e-8, atol=1e-8)
    assert r.noise_variance == pytest.approx(sigma2, rel=1e-8)
    Phi, _ = ref.arx_regressors(y, u[:, None], 9, [10], [17])
    np.testing.assert_allclose(r.covariance, sigma2 * np.linalg.inv(Phi.T @ Phi), rtol=1e-6)
    assert r.a[0] == 1.0 and np.allclose(r.a[1:], theta[:9])
    assert r.equations == 1440 - 26


def test_arx_miso_equals_lstsq():
    chans = [([0.5], [1, -0.7], 3), ([0.2, 0.1], [1, -0.5], 1), ([-0.3], [1.0], 5)]
    y, u = open_loop(600, 1, chans)
    nb, delays = [4, 6, 3], [3, 1, 5]
    r = identify.arx(y, u, 5, nb, delays)
    theta, sigma2, _ = ref.arx(y, u, 5, nb, delays, delta=1e-4)
    np.testing.assert_allclose(r.theta, theta, rtol=1e-8, atol=1e-8)
    assert [len(b) for b in r.b] == nb
    np.testing.assert_allclose(np.concatenate(r.b), theta[5:], rtol=1e-8, atol=1e-8)


def test_arx_regularisation_rule_matches_ridge_reference(siso_closed_loop):
    # A large delta makes the Section 3.1 rule engage; a tiny one leaves plain LS.
    y, u = siso_closed_loop
    for delta, expect in [(0.5, True), (1e-12, False)]:
        r = identify.arx(y, u, 9, 10, 17, delta=delta)
        theta, _, regularised = ref.arx(y, u[:, None], 9, [10], [17], delta=delta)
        assert r.regularised == regularised == expect
        np.testing.assert_allclose(r.theta, theta, rtol=1e-8, atol=1e-8)
        # Covariance: the sandwich sigma^2 M G M, M = (G + delta/2 diag(G))^-1 (the ridge
        # in original coordinates; M = G^-1 when the rule does not engage).
        Phi, _ = ref.arx_regressors(y, u[:, None], 9, [10], [17])
        G = Phi.T @ Phi
        M = np.linalg.inv(G + (0.5 * delta if expect else 0.0) * np.diag(np.diag(G)))
        np.testing.assert_allclose(r.covariance, r.noise_variance * M @ G @ M, rtol=1e-6)


def _oe_reference(y, u, chans, x0, skip):
    return ref.oe(y, u, chans, np.asarray(x0, float), skip=skip)


def test_oe_foptd_siso_equals_least_squares(siso_closed_loop):
    y, u = siso_closed_loop
    r = identify.oe(y, u, 17, "foptd", skip=9)
    theta = _oe_reference(y, u[:, None], [(1, 1, 17)], [0.05, -0.5], 9)
    assert r.converged
    np.testing.assert_allclose(r.theta, theta, rtol=1e-8, atol=1e-8)
    eps = (y - ref.simulate(theta, u[:, None], [(1, 1, 17)]))[9:]
    assert r.cost == pytest.approx(0.5 * eps @ eps, rel=1e-10)


def test_oe_miso_general_equals_least_squares():
    true = [([0.4, 0.2], [1, -1.2, 0.5], 2), ([0.3], [1, -0.8], 4), ([0.1, -0.05], [1.0], 1)]
    y, u = open_loop(800, 2, true)
    chans = [(2, 2, 2), (1, 1, 4), (2, 0, 1)]
    r = identify.oe(y, u, [2, 4, 1], "oe", nb=[2, 1, 2], nf=[2, 1, 0])
    x0 = [0.3, 0.1, -1.0, 0.3, 0.2, -0.6, 0.0, 0.0]
    theta = _oe_reference(y, u, chans, x0, 0)
    assert r.converged
    np.testing.assert_allclose(r.theta, theta, rtol=1e-8, atol=1e-8)
    # The covariance is sigma^2 (J'J)^-1 at the optimum.
    J = ref.oe_jacobian(theta, u, chans, 0)
    sigma2 = 2 * r.cost / (800 - 8)
    np.testing.assert_allclose(r.covariance, sigma2 * np.linalg.inv(J.T @ J), rtol=1e-6)


def test_oe_first_order_with_two_b_taps_equals_least_squares():
    # nf = 1 with nb = 2: the start's pole grid solves a 2-tap least squares per pole.
    y, u = open_loop(600, 7, [([0.3, 0.15], [1, -0.7], 3)])
    r = identify.oe(y, u, [3], "oe", nb=[2], nf=[1])
    theta = _oe_reference(y, u, [(2, 1, 3)], [0.3, 0.15, -0.7], 0)
    assert r.converged
    np.testing.assert_allclose(r.theta, theta, rtol=1e-8, atol=1e-8)


def test_fir_recovers_known_fir_and_equals_lstsq():
    g = np.array([0.5, 0.3, -0.2, 0.1, 0.05])
    rng = np.random.default_rng(4)
    u = rng.standard_normal((300, 1))
    y = ss.lfilter(np.r_[np.zeros(3), g], [1.0], u[:, 0])
    r = identify.oe(y, u, 3, "fir", nb=5)
    np.testing.assert_allclose(r.b[0], g, atol=1e-12)
    y_noisy = y + 0.1 * rng.standard_normal(300)
    r = identify.oe(y_noisy, u, 3, "fir", nb=5, skip=10)
    t = np.arange(10, 300)
    Phi = np.column_stack([u[t - 3 - k, 0] for k in range(5)])
    np.testing.assert_allclose(r.b[0], np.linalg.lstsq(Phi, y_noisy[t], rcond=None)[0],
                               rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("detrend", ["mean", "linear"])
def test_arx_oe_pipeline_equals_reference(siso_closed_loop, detrend):
    y, u = siso_closed_loop
    y = y + 23.75 + (1e-4 * np.arange(len(y)) if detrend == "linear" else 0.0)
    u = u + 131.0
    L = identify.fir_length_to_one_percent(identify._core.TransferFunction(*G0))
    r = identify.arx_oe(y, u, 9, 10, 17, fir_length=L, detrend=detrend)
    theta, a, gains, firs = ref.arx_oe(y, u[:, None], 9, [10], [17], [(1, 1, 17)], [L],
                                       detrend="constant" if detrend == "mean" else "linear")
    np.testing.assert_allclose(r.oe.theta, theta, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(r.noise, a[1:], rtol=1e-8, atol=1e-8)
    ch = r.channels[0]
    assert ch.gain == pytest.approx(gains[0], rel=1e-8)
    np.testing.assert_allclose(ch.fir, firs[0], rtol=1e-8, atol=1e-10)
    assert len(ch.fir) == L and np.all(ch.fir[:17] == 0.0)


def test_arx_oe_miso_pipeline_equals_reference():
    chans_true = [([0.3], [1, -0.6], 4), ([-0.2], [1, -0.3], 2)]
    y, u = open_loop(1000, 5, chans_true)
    r = identify.arx_oe(y, u, 6, [6, 6], [4, 2], fir_length=[20, 20])
    theta, a, gains, _ = ref.arx_oe(y, u, 6, [6, 6], [4, 2], [(1, 1, 4), (1, 1, 2)], [20, 20])
    np.testing.assert_allclose(r.oe.theta, theta, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose([c.gain for c in r.channels], gains, rtol=1e-8)


def test_arx_oe_reuses_its_estimator_without_changing_results(siso_closed_loop):
    # arx_oe keeps one estimator per settings (and thread): a reused estimator gives
    # exactly what a fresh one gives, on another window, and other settings are not
    # served by it.
    y, u = siso_closed_loop
    first = identify.arx_oe(y[:1000], u[:1000], 9, 10, 17, fir_length=64)
    again = identify.arx_oe(y[300:], u[300:], 9, 10, 17, fir_length=64)
    fresh = identify._core.ArxOeEstimator(9, [10], [17], identify.channels(17), [64]).estimate(
        y[300:], u[300:, None])
    assert np.array_equal(again.oe.theta, fresh.oe.theta)
    assert np.array_equal(again.channels[0].fir, fresh.channels[0].fir)
    assert not np.array_equal(first.oe.theta, again.oe.theta)
    other = identify.arx_oe(y[300:], u[300:], 5, 6, 17, fir_length=30)
    assert len(other.noise) == 5 and len(other.channels[0].fir) == 30
    assert identify.arx_oe(y[300:], u[300:], 9, [10], [17], fir_length=[64]).oe.theta.tolist() == \
        fresh.oe.theta.tolist()


def test_fir_length_default_is_one_percent_of_peak():
    g = ss.lfilter(np.r_[np.zeros(17), 0.1003], [1.0, -0.9048], np.r_[1.0, np.zeros(999)])
    expected = np.nonzero(np.abs(g) >= 0.01 * np.abs(g).max())[0][-1] + 1
    assert identify.fir_length_to_one_percent(identify._core.TransferFunction(*G0)) == expected
    with pytest.raises(ValueError, match="1%"):
        identify.fir_length_to_one_percent(identify._core.TransferFunction([1.0], [1.0, -1.0]))


# --- non-informative data: a clear error or a flagged window, never garbage -----------

def test_constant_input_is_an_error(siso_closed_loop):
    y, _ = siso_closed_loop
    u = np.full(len(y), 131.0)
    for call in (lambda: identify.arx(y, u, 9, 10, 17),
                 lambda: identify.oe(y, u, 17),
                 lambda: identify.arx_oe(y, u, 9, 10, 17)):
        with pytest.raises(RuntimeError, match=r"u\[0\] is constant"):
            call()


def test_nan_window_is_an_error_and_a_flagged_window(siso_closed_loop):
    y, u = siso_closed_loop
    with pytest.raises(RuntimeError, match="non-finite"):
        identify.arx_oe(np.full(len(y), np.nan), u, 9, 10, 17)
    y2 = y.copy()
    y2[700] = np.nan
    windows = identify.arx_oe_windows(y2, u, 400, 200, 9, 10, 17)
    assert [w.start for w in windows] == [0, 200, 400, 600, 800, 1000]
    assert [w.ok for w in windows] == [True, True, False, False, True, True]
    assert "y has 1 non-finite" in windows[2].message
    assert windows[0].message == ""


def test_too_short_window_is_an_error(siso_closed_loop):
    y, u = siso_closed_loop
    with pytest.raises(RuntimeError, match="too short"):
        identify.arx_oe(y[:60], u[:60], 9, 10, 17)
    with pytest.raises(RuntimeError, match="too short"):
        identify.oe(y[:3], u[:3], 0, "fir", nb=2)


def test_collinear_inputs_are_an_error():
    y, u = open_loop(500, 6, [([0.3], [1, -0.6], 2)])
    u2 = np.column_stack([u[:, 0], 2.0 * u[:, 0]])  # the same input twice
    with pytest.raises(RuntimeError, match="collinear"):
        identify.arx(y, u2, 4, [4, 4], [2, 2])
    with pytest.raises(RuntimeError, match="not informative"):
        identify.oe(y, u2, [2, 2], "fir", nb=3)


def test_bad_arguments_are_value_errors():
    y, u = open_loop(300, 7, [([0.3], [1, -0.6], 2)])
    with pytest.raises(ValueError, match="delays"):
        identify.arx(y, u, 4, [4], [2, 3])
    with pytest.raises(ValueError, match="na"):
        identify.arx(y, u, -1, 4, 2)
    with pytest.raises(ValueError, match="rows"):
        identify.arx(y, u[:-1], 4, 4, 2)
    with pytest.raises(ValueError, match="structure"):
        identify.oe(y, u, 2, "bj")
    with pytest.raises(ValueError, match="detrend"):
        identify.arx_oe(y, u, 4, 4, 2, detrend="quadratic")


def test_arx_oe_model_uses_the_models_channels_and_delays():
    # Paper MIMO scenario, output 2 (press_moisture <- stock_flow, steam_4): the model +
    # data entry point must give exactly the array call with the nominal delays/orders.
    import mpmpp
    spec = mpmpp.scenarios.paper_mimo()
    spec["events"] = []
    spec["duration_s"] = 2000 * spec["sample_time_s"]
    data = mpmpp.simulate(spec, seed=1)
    model = mpmpp.Model.from_json(__import__("json").dumps(
        {k: spec[k] for k in ("name", "sample_time_s", "inputs", "outputs", "process", "noise")}))
    assert identify.channel_inputs(model, "press_moisture") == ["stock_flow", "steam_4"]
    r = identify.arx_oe_model(model, data, "press_moisture", na=18, nb=10)
    direct = identify.arx_oe(data["press_moisture"], data[["stock_flow", "steam_4"]], 18, 10,
                             [19, 23], structure="oe", oe_nb=[1, 1], oe_nf=[1, 1],
                             fir_length=[len(c.fir) for c in r.channels])
    np.testing.assert_array_equal(r.oe.theta, direct.oe.theta)
    lengths = [identify.fir_length_to_one_percent(model.process("press_moisture", i))
               for i in ("stock_flow", "steam_4")]
    assert [len(c.fir) for c in r.channels] == lengths
    windows = identify.arx_oe_model(model, data, "press_moisture", na=18, nb=10,
                                    window=1000, step=500)
    assert [w.start for w in windows] == [0, 500, 1000] and all(w.ok for w in windows)
    with pytest.raises(ValueError, match="not in the model"):
        identify.arx_oe_model(model, data, "caliper")
