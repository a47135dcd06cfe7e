"""A few lost output samples are interpolated instead of cutting the record
(signals.bridge_lost_outputs), and the errors that read them are left out (signals.bridged_reach)."""
import numpy as np
import pytest

import mpmpp
from mpmpp.compare import compare
from mpmpp.diagnose import diagnose
from mpmpp.diagnose.whitening import NOISE_ORDER, estimated_noise_note
from mpmpp.model_identification import model_from_data
from mpmpp.signals import MAX_BRIDGED_SHARE, bridge_lost_outputs, bridged_reach, extract

import pi_loop


def test_short_runs_are_interpolated_between_their_neighbours():
    y = np.arange(400.0).reshape(200, 2) ** 1.5
    lost = y.copy()
    lost[50, 0] = np.nan
    lost[[120, 121], 1] = np.nan
    filled, mask = bridge_lost_outputs(lost, np.ones((200, 1)))
    assert np.flatnonzero(mask[:, 0]).tolist() == [50] and np.flatnonzero(mask[:, 1]).tolist() == [120, 121]
    assert filled[50, 0] == pytest.approx((y[49, 0] + y[51, 0]) / 2)
    assert filled[[120, 121], 1] == pytest.approx(y[119, 1] + (y[122, 1] - y[119, 1]) * np.array([1, 2]) / 3)
    assert np.array_equal(filled[~mask], y[~mask])


@pytest.mark.parametrize("rows, inputs_lost, starts", [
    ([60, 61, 62], [], []),   # three in a row: too long a run
    ([0], [], []),            # no sample before it
    ([199], [], []),          # no sample after it
    ([60], [61], []),         # an input lost beside it
    ([60], [], [61]),         # a segment starts (time gap) right after it
])
def test_runs_that_are_not_interpolated(rows, inputs_lost, starts):
    y = np.ones((200, 1))
    y[rows, 0] = np.nan
    inputs = np.ones((200, 1))
    inputs[inputs_lost] = np.nan
    filled, mask = bridge_lost_outputs(y, inputs, starts)
    assert not mask.any() and np.isnan(filled[rows, 0]).all()


def test_an_output_losing_more_than_its_share_keeps_every_gap():
    n = 1000
    y = np.ones((n, 2))
    many = np.arange(10, n - 10, 90)[: int(MAX_BRIDGED_SHARE * n) + 1]
    y[many, 0] = np.nan
    y[500, 1] = np.nan
    filled, mask = bridge_lost_outputs(y, np.ones((n, 1)))
    assert not mask[:, 0].any() and np.isnan(filled[many, 0]).all()
    assert np.flatnonzero(mask[:, 1]).tolist() == [500]


def _flow_model(gain_factor=1.0, noise=None):
    loop = pi_loop.FLOW
    g = mpmpp.TransferFunction.from_foptd(loop.gain * gain_factor, loop.time_constant_s, loop.dead_time_s, 10.0)
    return mpmpp.Model("flow", 10.0, ["OP"], ["PV"], {"PV": {"OP": g}}, {"PV": noise} if noise else {})


def test_the_reach_of_an_interpolated_sample_through_the_noise_filter():
    """H^-1 = 1 - 0.5 q^-1 reads a sample for two rows (its impulse response); an AR of 5 lags
    on top of it, five more."""
    data = pi_loop.simulate(pi_loop.FLOW, 1)
    data.loc[300, "PV"] = np.nan
    h = mpmpp.TransferFunction([1.0], [1.0, -0.5], 0)
    sig = extract(_flow_model(noise=h), data)
    assert sig.segments == [(0, 751)] and np.flatnonzero(sig.bridged[:, 0]).tolist() == [300]
    assert np.flatnonzero(bridged_reach(sig, 0, h.inverse(), 5)).tolist() == list(range(300, 307))
    assert not bridged_reach(extract(_flow_model(), pi_loop.simulate(pi_loop.FLOW, 1)), 0, h.inverse(), 5).any()


def test_diagnose_keeps_a_two_hour_record_whole_across_lost_pv_samples():
    """The level loop, its model's gain 1.6x the plant's, four PV samples lost: the record was cut
    into pieces and the short ones dropped (half of it), and a stick-slip valve was named at
    confidence 0.97. Interpolated, the gain error is named as on the complete record."""
    loop = pi_loop.LEVEL
    g = mpmpp.TransferFunction.from_foptd(loop.gain * 1.6, loop.time_constant_s, loop.dead_time_s, 10.0)
    model = mpmpp.Model("level", 10.0, ["OP"], ["PV"], {"PV": {"OP": g}})
    data = pi_loop.simulate(loop, 3, setpoint_steps=True)
    complete = diagnose(model, data)
    data.loc[[383, 533, 644, 687], "PV"] = np.nan
    gappy = diagnose(model, data)
    for res in (complete, gappy):
        top = res.findings[0]
        assert (top.effect, top.onset_s) == ("gain", 0.0)
        assert 0.55 < top.estimate["gain_ratio"] < 0.75
    assert any(n.startswith("PV: 4 lost sample(s)") and "interpolated" in n for n in gappy.notes)
    assert not any("lost sample" in n for n in complete.notes)


def test_compare_leaves_out_the_errors_that_read_an_interpolated_sample():
    data = pi_loop.simulate(pi_loop.FLOW, 2, setpoint_steps=True)
    data.loc[[200, 201, 500], "PV"] = np.nan
    res = compare(_flow_model(), data)
    assert res.interpolated_samples == 3 and res.skipped_rows == 0
    assert "3 lost output sample(s) interpolated" in res.summary()
    # the model has no noise model: compare estimates H = 1 / A(q), A of order NOISE_ORDER, so
    # the one-step error at t reads y(t - NOISE_ORDER .. t)
    reach = NOISE_ORDER
    lost = np.r_[200:202 + reach, 500:501 + reach]
    assert np.isnan(res.outputs[0].residual[lost]).all()
    assert np.isfinite(res.outputs[0].residual[[199, 202 + reach, 499, 501 + reach]]).all()
    assert res.disturbance == [estimated_noise_note("PV")]


def test_identify_keeps_a_two_hour_record_whole_across_lost_pv_samples():
    """Seven PV samples lost (0.9 %): cut at them, the record fell into seven stretches, most
    too short to fit from rest; interpolated, the estimates stay within a few per cent of the
    complete record's."""
    data = pi_loop.simulate(pi_loop.PRESSURE, 2, setpoint_steps=True)
    complete = model_from_data(data, ["OP"], ["PV"]).channels[0]
    data.loc[[40, 150, 151, 333, 500, 610, 700], "PV"] = np.nan
    r = model_from_data(data, ["OP"], ["PV"])
    assert (r.rows_used, r.skipped_rows, r.interpolated_samples) == (751, 0, 7)
    assert "7 lost output sample(s) interpolated" in r.summary()
    c = r.channels[0]
    assert c.gain == pytest.approx(complete.gain, rel=0.02)
    assert c.time_constant_s == pytest.approx(complete.time_constant_s, rel=0.03)
    assert c.dead_time_s == pytest.approx(complete.dead_time_s, abs=5.0)
