"""The step-response error between two channels (python/mpmpp/step_response.py) against a
plain NumPy recursion."""
import numpy as np
import pytest

from mpmpp import _core
from mpmpp import step_response as sr


def numpy_step(b, a, delay, n):
    """Step response of b / (1 - a q^-1) q^-delay by its difference equation."""
    y, out = 0.0, np.zeros(n)
    for k in range(n):
        y = a * y + (b if k - delay >= 0 else 0.0)
        out[k] = y
    return out


def test_step_error_matches_numpy():
    true = _core.TransferFunction([0.2], [1.0, -0.8], 3)
    model = _core.TransferFunction([0.1], [1.0, -0.8], 5)
    n = sr.settling_samples(true, model)
    assert n >= 5 + 5 * (-1 / np.log(0.8))
    ref = numpy_step(0.2, 0.8, 3, n) - numpy_step(0.1, 0.8, 5, n)
    assert sr.step_response_error(model, true) == pytest.approx(np.sqrt(np.mean(ref**2)) / 1.0, rel=1e-9)
    assert sr.step_response_error(true, true) == 0.0
    # a missing channel: the whole true response is the error
    assert sr.step_response_error(None, true) == pytest.approx(np.sqrt(np.mean(numpy_step(0.2, 0.8, 3, sr.settling_samples(true)) ** 2)))


def test_step_deviation_is_the_largest_difference():
    true = _core.TransferFunction([0.2], [1.0, -0.8], 3)
    model = _core.TransferFunction([0.1], [1.0, -0.8], 5)
    ref = numpy_step(0.2, 0.8, 3, sr.settling_samples(true, model)) - numpy_step(0.1, 0.8, 5, sr.settling_samples(true, model))
    assert sr.step_response_deviation(model, true) == pytest.approx(np.max(np.abs(ref)), rel=1e-9)
    # analytic: a gain ratio k deviates by |k - 1| (to 1e-3: the horizon ends 5 time constants
    # past the dead time, at 99.3 % of the gain); a first-order lag with its time constant
    # doubled by 1/4 at t = 2 tau ln 2 (continuous time; the sampled peak is within 1e-3 for a
    # 50-sample time constant)
    assert sr.step_response_deviation(_core.TransferFunction([0.26], [1.0, -0.8], 3), true) == pytest.approx(0.3, rel=2e-3)
    a = np.exp(-1 / 50.0)
    fast, slow = (_core.TransferFunction([1 - p], [1.0, -p], 0) for p in (a, np.sqrt(a)))
    assert sr.step_response_deviation(slow, fast) == pytest.approx(0.25, abs=1e-3)
