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
