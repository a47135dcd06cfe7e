"""TransferFunction against scipy.signal / numpy on randomised cases (hypothesis), to 1e-10."""
import math
import warnings

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st
from scipy import signal
from scipy.optimize import linear_sum_assignment

import mpmpp

# Relative to the signal's size: a cascade of two 4th-order filters with poles up to 0.95
# differs from the composed filter by up to ~1e-11 of its peak in rounding alone.
TOL = 1e-10
PROPERTY = settings(max_examples=100, deadline=None)


def assert_close(actual, expected):
    """Equal to TOL relative to the size of the signal (absolute for signals of size <= 1)."""
    actual, expected = np.asarray(actual), np.asarray(expected)
    assert actual.shape == expected.shape
    scale = max(1.0, float(np.max(np.abs(expected), initial=0.0)))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=TOL * scale)


@st.composite
def polynomial(draw, max_degree=4, max_radius=0.95, min_gap=0.1):
    """A q^-1 polynomial with a random non-zero leading coefficient and roots drawn in the
    disc |z| <= max_radius (real or complex-conjugate pairs), at least min_gap apart so that
    the roots are well conditioned (a double root is only defined to ~sqrt(eps))."""
    lead = draw(st.floats(0.5, 2.0)) * draw(st.sampled_from([-1.0, 1.0]))
    roots = []
    while len(roots) < draw(st.integers(0, max_degree)):
        # A root exactly at 0 or clearly away from it: a root at 1e-38 is one at 0 to rounding.
        radius = draw(st.one_of(st.just(0.0), st.floats(0.05, max_radius)))
        if len(roots) + 2 <= max_degree and draw(st.booleans()):
            angle = draw(st.floats(0.2, math.pi - 0.2))
            roots += [radius * complex(math.cos(angle), math.sin(angle)),
                      radius * complex(math.cos(angle), -math.sin(angle))]
        else:
            roots.append(radius * draw(st.sampled_from([-1.0, 1.0])))
    gaps = [abs(a - b) for k, a in enumerate(roots) for b in roots[k + 1:]]
    assume(min(gaps, default=1.0) >= min_gap)
    return lead * np.real(np.poly(roots)) if roots else np.array([lead])


@st.composite
def transfer_function(draw):
    num = draw(polynomial(max_radius=1.8))
    den = draw(polynomial())
    delay = draw(st.integers(0, 5))
    return num, den, delay


def lfilter_reference(num, den, delay, x):
    return signal.lfilter(np.r_[np.zeros(delay), num], den, x)


def z_polynomials(num, den, delay):
    """q^-1 coefficient lists -> numerator and denominator in descending powers of z."""
    b = np.r_[np.zeros(delay), num]
    n = max(len(b), len(den))
    return np.r_[b, np.zeros(n - len(b))], np.r_[den, np.zeros(n - len(den))]


def nonzero_roots(c):
    """np.roots of a q^-1 polynomial without the roots at the origin, which only a delay
    (trailing zero coefficients) puts there: np.roots adds those as exact zeros."""
    r = np.roots(c)
    return r[r != 0]


def assert_same_roots(actual, expected):
    actual, expected = np.asarray(actual, dtype=complex), np.asarray(expected, dtype=complex)
    assert actual.shape == expected.shape
    if actual.size == 0:
        return
    distance = np.abs(actual[:, None] - expected[None, :])
    rows, cols = linear_sum_assignment(distance)
    assert distance[rows, cols].max() <= TOL * max(1.0, np.abs(expected).max())


signals = st.integers(1, 60).flatmap(
    lambda n: st.lists(st.floats(-10, 10), min_size=n, max_size=n).map(np.array))


@PROPERTY
@given(tf=transfer_function(), x=signals)
def test_filter_matches_lfilter(tf, x):
    num, den, delay = tf
    assert_close(mpmpp.TransferFunction(num, den, delay).filter(x), lfilter_reference(num, den, delay, x))


@PROPERTY
@given(tf=transfer_function(), n=st.integers(1, 80))
def test_impulse_and_step_match_dimpulse_dstep(tf, n):
    num, den, delay = tf
    g = mpmpp.TransferFunction(num, den, delay)
    system = (*z_polynomials(num, den, delay), 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", signal.BadCoefficients)  # leading zeros of a delay
        # One sample more than needed: scipy returns NaN when asked for a single sample.
        _, (impulse,) = signal.dimpulse(system, n=n + 1)
        _, (step,) = signal.dstep(system, n=n + 1)
    assert_close(g.impulse(n), impulse[:n, 0])
    assert_close(g.step(n), step[:n, 0])


@PROPERTY
@given(tf=transfer_function())
def test_poles_zeros_and_stability_match_numpy_roots(tf):
    num, den, delay = tf
    g = mpmpp.TransferFunction(num, den, delay)
    assert_same_roots(g.poles(), nonzero_roots(den))
    assert_same_roots(g.zeros(), nonzero_roots(num))
    largest_zero = np.abs(nonzero_roots(num)).max(initial=0.0)
    assume(abs(largest_zero - 1.0) > 1e-9)  # on the circle is a matter of rounding
    assert g.is_stable()  # the strategy draws poles with |z| <= 0.95
    assert g.is_minimum_phase() == (largest_zero < 1.0)


@PROPERTY
@given(tf=transfer_function())
def test_dc_gain_is_the_final_step_value(tf):
    num, den, delay = tf
    g = mpmpp.TransferFunction(num, den, delay)
    assert math.isclose(g.dc_gain(), np.sum(num) / np.sum(den), rel_tol=1e-13, abs_tol=1e-13)


@PROPERTY
@given(a=transfer_function(), b=transfer_function(), x=signals)
def test_series_and_parallel_match_composed_responses(a, b, x):
    ga, gb = mpmpp.TransferFunction(*a), mpmpp.TransferFunction(*b)
    ya, yb = lfilter_reference(*a, x), lfilter_reference(*b, x)
    assert_close(ga.series(gb).filter(x), lfilter_reference(*b, ya))
    assert_close(ga.parallel(gb).filter(x), ya + yb)


@PROPERTY
@given(gain=st.floats(-5, 5), tau=st.floats(0.5, 500), ts=st.floats(0.1, 20), d=st.integers(0, 20))
def test_foptd_integer_dead_time_matches_cont2discrete(gain, tau, ts, d):
    g = mpmpp.TransferFunction.from_foptd(gain, tau, d * ts, ts)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", signal.BadCoefficients)  # its b has a leading zero
        numd, dend, _ = signal.cont2discrete(([gain], [tau, 1.0]), ts, method="zoh")
    # cont2discrete gives b in powers of z of the same degree as a: [0, b1] = b1 q^-1.
    reference = lfilter_reference(np.ravel(numd), dend, d, np.ones(80))
    assert_close(g.step(80), reference)


@PROPERTY
@given(gain=st.floats(-5, 5), tau=st.floats(0.0, 500), ts=st.floats(0.1, 20),
       d=st.integers(0, 20), f=st.floats(0.001, 0.999))
def test_foptd_fractional_dead_time_matches_sampled_step(gain, tau, ts, d, f):
    theta = (d + f) * ts
    g = mpmpp.TransferFunction.from_foptd(gain, tau, theta, ts)
    t = ts * np.arange(80)
    # The continuous step response sampled at t = k Ts: exact for a ZOH input.
    with np.errstate(over="ignore", invalid="ignore"):  # before the dead time; discarded by where
        expected = np.where(t > theta, gain * (1.0 - np.exp(-(t - theta) / tau)) if tau > 0 else gain, 0.0)
    assert_close(g.step(80), expected)
    assert math.isclose(g.dc_gain(), gain, rel_tol=1e-12, abs_tol=1e-12)


def test_foptd_rejects_bad_parameters():
    with pytest.raises(ValueError, match="time_constant_s must be >= 0"):
        mpmpp.TransferFunction.from_foptd(1.0, -1.0, 0.0, 1.0)
    with pytest.raises(ValueError, match="dead_time_s must be >= 0"):
        mpmpp.TransferFunction.from_foptd(1.0, 1.0, -1.0, 1.0)
    with pytest.raises(ValueError, match="sample_time_s must be > 0"):
        mpmpp.TransferFunction.from_foptd(1.0, 1.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="dead_time_s"):
        mpmpp.TransferFunction.from_foptd(1.0, 1.0, 1e300, 1.0)


def test_inverse_undoes_the_filter():
    g = mpmpp.TransferFunction([1.0, -0.4, 0.1], [1.0, 0.5])
    x = np.random.default_rng(0).standard_normal(50)
    assert_close(g.inverse().filter(g.filter(x)), x)
    with pytest.raises(ValueError, match="delay"):
        mpmpp.TransferFunction([1.0], [1.0], 2).inverse()


def test_str_is_readable():
    assert str(mpmpp.TransferFunction([0.063], [1.0, -0.93], 14)) == "q^-14 (0.063) / (1 - 0.93 q^-1)"
    assert str(mpmpp.TransferFunction([1.0, 0.0, 0.25], [2.0])) == "(0.5 + 0.125 q^-2)"


def test_filter_over_stretches_restarts_each_from_rest_as_scipy():
    """A record of stretches laid end to end (``stretch_starts``): each filtered from rest,
    as scipy's lfilter of each stretch alone; bad starts are a clear error."""
    import scipy.signal as ss

    g = mpmpp.TransferFunction(np.array([0.2, 0.1]), np.array([1.0, -0.8]), 2)
    x = np.random.default_rng(0).standard_normal(300)
    spans = [(0, 100), (100, 101), (101, 250), (250, 300)]
    want = np.concatenate([ss.lfilter([0, 0, 0.2, 0.1], [1, -0.8], x[a:b]) for a, b in spans])
    np.testing.assert_allclose(g.filter(x, stretch_starts=[100, 101, 250]), want, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(g.filter(x, stretch_starts=[]), g.filter(x))
    with pytest.raises(ValueError, match="stretch_starts must be strictly increasing"):
        g.filter(x, stretch_starts=[250, 100])
