"""Spikes in y and heavy-tailed innovations are not a disturbance change (diagnose/noise.py):
the spikes' tails are taken out of the one-step error before a new noise colour is scored, and
the innovation-level likelihood ratio is scaled for the innovations' kurtosis."""
import numpy as np
import pytest
from scipy.signal import lfilter

from mpmpp import families as fam
from mpmpp._core import TransferFunction
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose
from mpmpp.diagnose.pipeline import diagnosis_signals
from mpmpp.diagnose.spikes import SPIKE_SIGMAS, without_spikes
from mpmpp.evaluate import nominal_model
from mpmpp.simulate import simulate

# H^-1 = (1 - 0.3 q^-1) / (1 - 0.9 q^-1): a spike in v leaves a long tail in e = H^-1 v
HINV_NUM, HINV_DEN = [1.0, -0.3], [1.0, -0.9]


def _record(rng, n, spikes):
    w = rng.standard_normal(n)
    s = np.zeros(n)
    s[spikes] = rng.choice([-1.0, 1.0], len(spikes)) * 15.0
    v = lfilter(HINV_DEN, HINV_NUM, w) + s                # v = H w + spikes
    return w, s, v, lfilter(HINV_NUM, HINV_DEN, v)      # e = H^-1 v


def test_spike_tails_leave_the_one_step_error_as_the_additive_outlier_model_says():
    rng = np.random.default_rng(11)
    n = 4000
    spikes = np.sort(rng.choice(np.arange(100, n - 100), 20, replace=False))
    w, s, v, e = _record(rng, n, spikes)
    cleaned = without_spikes(e, np.ones(n, bool), [(0, n)], TransferFunction(HINV_NUM, HINV_DEN, 0))
    # Reference: the recursion e(t) = 0.9 e(t-1) + v(t) - 0.3 v(t-1) run on a corrected v whose
    # value at each spike puts e(t) at e's median (the spike taken as the one-step error's
    # departure from its centre there).
    ref, corrected, centre = np.zeros(n), v.copy(), np.median(e)
    for t in range(n):
        past = 0.9 * ref[t - 1] - 0.3 * corrected[t - 1] if t else 0.0
        if t in spikes:
            corrected[t] = centre - past
        ref[t] = past + corrected[t]
    assert np.abs(cleaned - ref).max() < 1e-4
    # the spikes' sizes are recovered to within the noise, and away from them e is w again
    assert np.abs((v - corrected)[spikes] - s[spikes]).max() < 4.0
    assert np.abs(e - w).max() > 10.0 and np.sqrt(np.mean((cleaned - w) ** 2)) < 0.3


def test_records_without_spikes_or_with_heavy_tails_are_left_alone():
    rng = np.random.default_rng(12)
    n = 4000
    hinv = TransferFunction(HINV_NUM, HINV_DEN, 0)
    ok = np.ones(n, bool)
    e = rng.standard_normal(n)
    e[np.abs(e) > SPIKE_SIGMAS] = 0.0
    assert np.array_equal(without_spikes(e, ok, [(0, n)], hinv), e)
    # 15 % of the samples far out: heavy tails, not spikes
    wide = rng.standard_normal(n) * np.where(rng.uniform(size=n) < 0.15, 30.0, 1.0)
    assert np.array_equal(without_spikes(wide, ok, [(0, n)], hinv), wide)


@pytest.mark.parametrize("seed, output", [(6, "y1"), (12, "y2")])
def test_no_noise_change_on_a_right_model_with_spikes(seed, output):
    """Tuning-family draws (mpc_2x2_spiky, no change; high-pass / ARMA(2,2) noise with outliers)
    where an output had a noise_change finding: seed 6 a variance split x1.23 at kurtosis 18,
    seed 12 a new colour 'throughout the record' that the spikes' tails made predictable."""
    spec, expect = fam.family("mpc_2x2_spiky").draw(seed, None, "none")
    assert expect["kind"] == "none" and spec["truth"]["outliers"]["probability"] > 0
    result = diagnose(nominal_model(spec), simulate(spec))
    assert not [f.effect for f in result.findings if f.output == output and f.effect == "noise_change"]


def test_a_noise_change_with_spikes_is_still_found():
    """mpc_2x2_spiky seed 0: a new ARMA(1,1) colour on y2 (variance x1.03) among the spikes."""
    spec, expect = fam.family("mpc_2x2_spiky").draw(0, None, "noise_change")
    assert expect["output"] == "y2"
    result = diagnose(nominal_model(spec), simulate(spec))
    found = [f for f in result.findings if f.effect == "noise_change" and f.output == "y2"]
    assert found and abs(found[0].onset_s - expect["onset_s"]) < 3600.0


def _spiky_output_record(seed):
    """A tuning draw of mpc_2x2_spiky (no change) simulated without its outliers, and its model."""
    spec, _ = fam.family("mpc_2x2_spiky").draw(seed, None, "none")
    spec["truth"].pop("outliers")
    return nominal_model(spec), simulate(spec)


@pytest.mark.parametrize("seed", [1, 2])
def test_spikes_are_taken_out_of_the_output_before_any_fit(seed):
    """Spikes put into y1 of a spike-free closed-loop record are found at their rows and taken
    out: the output diagnose fits is the spike-free one up to the innovation at each spike (the
    spike is measured as the one-step error's whole departure there) and the record mean."""
    model, clean = _spiky_output_record(seed)
    rng = np.random.default_rng(seed)
    at = np.sort(rng.choice(np.arange(200, len(clean) - 10, 7), 12, replace=False))
    spiky = clean.copy()
    spiky.loc[at, "y1"] += rng.choice([-1.0, 1.0], len(at)) * 9.0
    got, want = diagnosis_signals(model, spiky), diagnosis_signals(model, clean)
    assert any("y1: 12 spike(s)" in n for n in got.notes)
    diff = got.sig.y[:, 0] - want.sig.y[:, 0]
    diff -= np.median(diff)
    assert np.abs(np.delete(diff, at)).max() < 1e-9
    assert np.abs(diff[at]).max() < 4.0


def test_a_step_of_the_output_is_no_spike():
    """A step of the output in the record's last rows (a drift, a change after a setpoint
    move) departs from the one-step error's centre at every row after it: no spike."""
    model, clean = _spiky_output_record(1)
    stepped = clean.copy()
    stepped.loc[len(clean) - 150:, "y1"] += 9.0
    assert not [n for n in diagnosis_signals(model, stepped).notes if "spike" in n]


def test_spikes_pose_as_no_process_change_in_closed_loop():
    """Tuning draw mpc_siso_disturbed seed 2, an output drift (no process change) among spikes:
    the controller answered the spikes, and with them in the record a dead time 5 samples
    instead of 4 stood from the drift's onset at 0.6; with them taken out, the drift alone."""
    spec, expect = fam.family("mpc_siso_disturbed").draw(2, None, "output_drift")
    assert expect["kind"] == "none" and spec["truth"]["outliers"]["probability"] > 0
    result = diagnose(nominal_model(spec), simulate(spec))
    assert any("spike(s)" in n for n in result.notes)
    assert [f.effect for f in result.findings if f.effect in PROCESS_EFFECTS] == []
    assert [f.effect for f in result.findings][:1] == ["output_drift"]
