"""The two-step covariance of ARX-OE's FIR estimate (two_step_covariance.hpp): equal to a
plain NumPy form of the same equations, its derivative M21 equal to finite differences of
the FIR least squares in A(q), and calibrated against the spread of estimates over
independent closed-loop runs of the paper MIMO example (where the OE step's own covariance
is half the real spread)."""
import numpy as np
import pytest

import mpmpp
from mpmpp import scenarios
from mpmpp.evaluate import nominal_model
from mpmpp.identify import arx_oe, arx_oe_model, channel_inputs

import identification_reference as ref

NA, NB = 18, 11
OUTPUT = "reel_moisture"


@pytest.fixture(scope="module")
def mimo():
    scenario = scenarios.paper_mimo()
    scenario["events"] = []
    return scenario, nominal_model(scenario)


def window(scenario, model, seed, end_h=6.0, hours=2.0):
    end = int(end_h * 3600 / model.sample_time_s)
    return mpmpp.simulate(scenario, seed=seed).iloc[end - int(hours * 3600 / model.sample_time_s):end]


def detrended(data, model):
    inputs = channel_inputs(model, OUTPUT)
    y = data[OUTPUT].to_numpy(dtype=float)
    u = data[inputs].to_numpy(dtype=float)
    return y - y.mean(), u - u.mean(axis=0), [model.process(OUTPUT, n).delay for n in inputs]


def test_equals_the_numpy_form_of_the_equations(mimo):
    scenario, model = mimo
    data = window(scenario, model, seed=1)
    y, u, delays = detrended(data, model)
    fir = [(2, d) for d in delays[:2]] + [(3, delays[2])]
    r = arx_oe(y, u, NA, NB, delays, structure="fir", oe_nb=[n for n, _ in fir], oe_nf=0,
               fir_length=[n + d for n, d in fir], two_step_covariance=True)
    expected, _, _ = ref.two_step_fir_covariance(y, u, NA, [NB] * 3, delays, fir,
                                                 np.asarray(r.arx.theta), np.asarray(r.oe.theta))
    np.testing.assert_allclose(r.two_step_covariance, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())
    # The A(q) term only adds: the result is at least the OE step's sandwich part.
    assert np.linalg.eigvalsh(expected).min() > 0


def test_m21_is_the_derivative_of_the_fir_estimate_in_a(mimo):
    """theta2(a) solves Z(a)' eps(a, theta2) = 0, so d theta2 / d a = (Z'Z)^-1 M21: central
    differences of the plain least squares in every a_k."""
    scenario, model = mimo
    y, u, delays = detrended(window(scenario, model, seed=2), model)
    fir = [(2, d) for d in delays]
    r = arx_oe(y, u, NA, NB, delays, structure="fir", oe_nb=2, oe_nf=0, fir_length=[2 + d for d in delays],
               two_step_covariance=True)
    a = np.asarray(r.arx.a)
    theta, _, _ = ref.fir_on_filtered(y, u, a, fir)
    np.testing.assert_allclose(theta, r.oe.theta, rtol=1e-9)
    _, M21, Z = ref.two_step_fir_covariance(y, u, NA, [NB] * 3, delays, fir, np.asarray(r.arx.theta), theta)
    analytic = np.linalg.solve(Z.T @ Z, M21[:, :NA])
    h = 1e-6
    for k in range(1, NA + 1):
        up, down = a.copy(), a.copy()
        up[k] += h
        down[k] -= h
        numeric = (ref.fir_on_filtered(y, u, up, fir)[0] - ref.fir_on_filtered(y, u, down, fir)[0]) / (2 * h)
        np.testing.assert_allclose(analytic[:, k - 1], numeric, rtol=1e-5, atol=1e-7 * np.abs(analytic).max())


def test_calibrated_against_the_spread_over_independent_runs(mimo):
    """40 closed-loop runs, one 2 h window each: the two-step standard deviations match the
    estimates' spread (within the ~11% sampling error of a 40-run sd, and the averaging of
    the predicted sd); the OE step's own covariance misses G32's spread by about half."""
    scenario, model = mimo
    estimates, two_step_sd, oe_sd = [], [], []
    for seed in range(40):
        r = arx_oe_model(model, window(scenario, model, seed, end_h=15.0), OUTPUT, na=NA, nb=NB, structure="fir",
                         two_step_covariance=True)
        estimates.append(np.asarray(r.oe.theta))
        two_step_sd.append(np.sqrt(np.diag(r.two_step_covariance)))
        oe_sd.append(np.sqrt(np.diag(r.oe.covariance)))
    spread = np.std(estimates, axis=0, ddof=1)
    ratio = spread / np.mean(two_step_sd, axis=0)
    assert ratio.min() > 0.7 and ratio.max() < 1.35, ratio
    g32 = slice(2, 4)  # reel_moisture <- steam_4: two taps after the delay
    assert (spread[g32] / np.mean(oe_sd, axis=0)[g32]).min() > 1.5


def test_needs_fir_structures():
    y = np.random.default_rng(0).standard_normal(400)
    u = np.random.default_rng(1).standard_normal((400, 1))
    with pytest.raises(ValueError, match="two_step_covariance needs FIR structures"):
        arx_oe(y, u, 4, 5, [1], structure="foptd", two_step_covariance=True)
    assert arx_oe(y, u, 4, 5, [1], structure="foptd").two_step_covariance.size == 0
