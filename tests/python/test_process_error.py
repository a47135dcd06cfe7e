"""The process-part error (diagnose/process_error.py) against a plain NumPy/SciPy computation of
the same quantity, and what it shows: a right fix makes it fall where the one-step error barely
moves."""
import numpy as np
import pytest
from scipy.signal import lfilter

from mpmpp.diagnose import diagnose
from mpmpp.diagnose.pipeline import diagnosis_signals
from mpmpp.diagnose.laguerre import LAGUERRE_FUNCTIONS, laguerre_filters, laguerre_pole
from mpmpp.diagnose.process_error import explanatory_columns, held_out_rms, process_error, process_parts
from mpmpp.diagnose.result import ModelChange
from mpmpp.update import update

import closed_loop_case as loop


def reference(y, u, channel, noise, pole, count, onset, block):
    """RMS on the odd blocks after onset of the Laguerre-basis part of y - G u: the basis
    responses of u (scipy lfilter), fitted by least squares of H^-1 (y - G u) on their H^-1
    filtered versions and a level H^-1 1 over the even blocks after onset (the level is not
    part of the reported quantity)."""
    num, den, d = channel
    v = y - lfilter(np.r_[np.zeros(d), num], den, u)
    e = lfilter(noise[1], noise[0], v)
    basis = [lfilter([0.0, np.sqrt(1 - pole**2)], [1.0, -pole], u)]
    for _ in range(count - 1):
        basis.append(lfilter([-pole, 1.0], [1.0, -pole], basis[-1]))
    x = np.column_stack(basis)
    n = len(y)
    xw = np.column_stack([lfilter(noise[1], noise[0], c) for c in [*basis, np.ones(n)]])
    t = np.arange(n)
    odd = (t // block) % 2 == 1
    fit, test = (t >= onset) & ~odd, (t >= onset) & odd
    b = np.linalg.lstsq(xw[fit], e[fit], rcond=None)[0][:count]
    return np.sqrt(np.mean((x[test] @ b) ** 2))


@pytest.mark.parametrize("gain_after", [1.0, 2.0])
def test_process_error_matches_numpy(gain_after):
    onset, block = 3000, 720
    data = loop.simulate(n=6000, seed=3, onset=onset, gain=2.0)
    sig = diagnosis_signals(loop.model(), data).sig
    assert sig.segments == [(0, len(data))]
    num, den, d = loop.G
    changes = [] if gain_after == 1.0 else [ModelChange(
        "y", "u", channel=loop.mpmpp.TransferFunction([num[0] * gain_after], den, d))]
    _, columns = explanatory_columns(sig, changes)
    pole = laguerre_pole(sig, 0)
    assert pole == pytest.approx(-den[1])          # the channel's (only) pole
    got = process_error(sig, 0, changes, onset, block, columns, laguerre_filters(pole))
    want = reference(sig.y[:, 0], sig.u[:, 0], ([num[0] * gain_after], den, d), loop.H, pole,
                     LAGUERRE_FUNCTIONS, onset, block)
    assert got == pytest.approx(want, rel=1e-5)   # near the floor the least squares amplifies round-off


def test_right_fix_shows_in_the_process_part(tmp_path):
    """Gain x2 at 4000: the finding's process-part error falls by more than half while the
    one-step error falls by a few per cent; diagnose and update report the same numbers."""
    data = loop.simulate(n=8000, seed=1, onset=4000, gain=2.0)
    res = diagnose(loop.model(), data)
    top = res.findings[0]
    assert top.effect == "gain"
    assert top.process_error_after < 0.5 * top.process_error_before
    one_step_fall = 1 - top.error_after / top.error_before
    assert 1 - top.process_error_after / top.process_error_before > 3 * one_step_fall
    d = top.to_dict()
    assert d["process_error_before"] == pytest.approx(top.process_error_before, abs=1e-6)
    assert "process part" in res.summary()
    before, after = res.process_parts[top.id]      # the series the figure draws
    odd_after_onset = (np.arange(len(before)) // 720 % 2 == 1) & (data["time"].to_numpy() >= top.onset_s)
    assert np.sqrt(np.mean(before[odd_after_onset] ** 2)) == pytest.approx(top.process_error_before, rel=1e-9)
    assert np.isnan(after[data["time"].to_numpy() < top.onset_s]).all()
    [figure] = res.plot(tmp_path)
    assert figure.stat().st_size > 0
    up = update(loop.model(), data, top.id)
    [err] = up.errors
    assert err.process_error_after < 0.5 * err.process_error_before
    assert up.to_dict()["errors"][0]["process_error_after"] == pytest.approx(err.process_error_after, abs=1e-6)
    assert "process part" in up.summary()


def test_no_change_stays_at_the_estimation_floor():
    """With the true model the process part is only the FIR's estimation error."""
    data = loop.simulate(n=8000, seed=2)
    sig = diagnosis_signals(loop.model(), data).sig
    _, columns = explanatory_columns(sig, [])
    filters = laguerre_filters(laguerre_pole(sig, 0))
    floor = process_error(sig, 0, [], 4000, 720, columns, filters)
    changed = loop.simulate(n=8000, seed=2, onset=4000, gain=2.0)
    sig2 = diagnosis_signals(loop.model(), changed).sig
    assert floor < 0.2 * process_error(sig2, 0, [], 4000, 720, columns, filters)


def test_too_short_after_the_onset_is_nan():
    data = loop.simulate(n=4000, seed=0)
    sig = diagnosis_signals(loop.model(), data).sig
    _, columns = explanatory_columns(sig, [])
    assert np.isnan(process_error(sig, 0, [], 3990, 720, columns, laguerre_filters(0.9)))


def test_a_noise_change_leaves_the_process_part_as_it_is():
    """G u is all the process part depends on. Both sides are whitened with the noise model
    after the change, so a noise-only change (a noise_change finding's update) shows the same
    process part before and after, and the one with a channel change is the NumPy reference
    under that noise model."""
    onset, block = 3000, 720
    data = loop.simulate(n=6000, seed=3, onset=onset, noise_den_after=[1.0, -0.9])
    sig = diagnosis_signals(loop.model(), data).sig
    new_noise = loop.mpmpp.TransferFunction(loop.H[0], [1.0, -0.9], 0)
    before, after = process_parts(sig, 0, [ModelChange("y", noise=new_noise)], onset, block)
    np.testing.assert_array_equal(before, after)
    num, den, d = loop.G
    doubled = ModelChange("y", "u", channel=loop.mpmpp.TransferFunction([2 * num[0]], den, d))
    before, after = process_parts(sig, 0, [doubled, ModelChange("y", noise=new_noise)], onset, block)
    pole = laguerre_pole(sig, 0)
    noise = (loop.H[0], [1.0, -0.9])
    for series, gain in ((before, 1.0), (after, 2.0)):
        want = reference(sig.y[:, 0], sig.u[:, 0], ([num[0] * gain], den, d), noise, pole, LAGUERRE_FUNCTIONS,
                         onset, block)
        assert held_out_rms(series, block) == pytest.approx(want, rel=1e-5)
