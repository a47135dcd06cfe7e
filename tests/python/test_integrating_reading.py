"""An integrating channel read back as rate gain, lag and dead time (mpmpp.foptd), against the
zero-order-hold discretisation of K e^(-theta s) / (s (tau s + 1)) computed here by SciPy."""
import numpy as np
import pytest
from scipy.signal import cont2discrete

import mpmpp
from mpmpp.foptd import integrating_parameters


def zoh_integrator(k, tau, theta, ts):
    """num, den, delay of K e^(-theta s) / (s (tau s + 1)) under a ZOH, theta a whole number of
    samples: SciPy's ZOH of the rational part, then theta / ts samples of delay."""
    den_s = [tau, 1.0, 0.0] if tau > 0 else [1.0, 0.0]
    num_z, den_z, _ = cont2discrete(([k], den_s), ts, method="zoh")
    num_z = np.trim_zeros(np.atleast_1d(np.squeeze(num_z)), "f")
    lead = len(den_z) - 1 - (len(num_z) - 1)  # z^-lead once written in q^-1
    return num_z, den_z, lead + int(round(theta / ts))


@pytest.mark.parametrize("k,tau,theta,ts", [(0.1, 0.0, 2.0, 1.0), (-0.03, 0.0, 30.0, 10.0),
                                            (0.2, 25.0, 10.0, 5.0), (0.05, 7.0, 0.0, 1.0)])
def test_rate_gain_lag_and_dead_time_are_read_back(k, tau, theta, ts):
    num, den, delay = zoh_integrator(k, tau, theta, ts)
    r = integrating_parameters(mpmpp.TransferFunction(num, den, delay), ts)
    assert r.rate_gain == pytest.approx(k, rel=1e-9)
    assert r.time_constant_s == pytest.approx(tau, rel=1e-9, abs=1e-9)
    assert r.dead_time_s == pytest.approx(theta, rel=1e-9, abs=1e-9)


def test_fractional_dead_time_and_non_integrating_channels():
    # theta = 2.5 Ts without a lag: b0 = b1 = K Ts / 2 after 3 samples (modified z-transform).
    r = integrating_parameters(mpmpp.TransferFunction([0.05, 0.05], [1.0, -1.0], 3), 1.0)
    assert (r.rate_gain, r.dead_time_s) == pytest.approx((0.1, 2.5))
    assert integrating_parameters(mpmpp.TransferFunction([0.1], [1.0, -0.9], 2), 1.0) is None
    assert integrating_parameters(mpmpp.TransferFunction([0.1], [1.0, -2.0, 1.0], 1), 1.0) is None


def test_an_integrator_whose_pole_rounds_below_one_is_no_crash():
    """The level of tuning family pi_level seed 4: den (1 - q^-1)(1 - 0.482 q^-1) written out,
    whose unit root comes out a rounding below 1, so the channel counts as stable with a DC gain
    of 6e14. The step-response reading found no sample that moved by 1e-9 of that gain within
    its window and raised IndexError (from `mpmpp check`, and from diagnose's dead-time text).
    It has no first-order reading, nor an integrating one (a lag behind a single numerator tap
    at lag 1 has a mean delay shorter than any dead time allows), so no dead time is stated: a
    delay finding on it speaks in samples."""
    from mpmpp.foptd import dead_time_s, foptd_parameters

    g = mpmpp.TransferFunction([0.03462617104458364], [1.0, -1.4820961093655292, 0.4820961093655292], 1)
    assert g.is_stable() and abs(g.dc_gain()) > 1e14
    assert foptd_parameters(g, 5.0) is None and integrating_parameters(g, 5.0) is None
    assert dead_time_s(g, 5.0) is None
    # the same level with the lag a ZOH gives it (two numerator taps) is read
    assert dead_time_s(mpmpp.TransferFunction(*zoh_integrator(0.2, 25.0, 10.0, 5.0)), 5.0) == pytest.approx(10.0)


def test_check_names_what_such_a_channel_may_be(tmp_path, capsys):
    """`mpmpp check` on that level: one line, the possible causes named (it raised IndexError)."""
    import json

    from mpmpp.cli import main

    path = tmp_path / "level.json"
    path.write_text(json.dumps({"name": "level", "sample_time_s": 5.0, "inputs": ["u1"], "outputs": ["y1"],
                                "process": {"y1": {"u1": {"num": [0.03462617104458364],
                                                          "den": [1.0, -1.4820961093655292, 0.4820961093655292],
                                                          "delay": 1}}}}))
    assert main(["check", str(path)]) == 0
    assert "no first-order or integrating reading (unstable, zero gain, or a pole at 1 within rounding)" in \
        capsys.readouterr().out
