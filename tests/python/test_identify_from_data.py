"""``model_from_data`` / ``mpmpp identify`` on PI loops from the NumPy reference simulator.

Checks against the truth (within the reported uncertainty), against SciPy's joint
prediction-error fit of the same structure, the verdicts (no excitation, no effect, sign
against the controller) and the command line on a 751-row, 10 s historian-length record.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

import identification_reference as ref
import pi_loop
from mpmpp import io
from mpmpp.cli import main
from mpmpp.identify import model_from_data
from mpmpp import structure_search as search
from mpmpp.channel_reading import SIGN_FLIP_Z, ChannelSummary, _profile_interval
from mpmpp.model_identification import NotIdentified, _check_verdict
from mpmpp.process_class import INTEGRATING, SELF_REGULATING
from mpmpp.stretches import Stretches


@pytest.mark.parametrize("loop", [pi_loop.FLOW, pi_loop.PRESSURE, pi_loop.LEVEL], ids=lambda l: l.name)
def test_pi_loop_with_setpoint_steps_recovers_the_process(loop):
    df = pi_loop.simulate(loop, seed=11, setpoint_steps=True)
    r = model_from_data(df, ["OP"], ["PV"])
    c, = r.channels
    assert r.sample_time_s == 10.0 and r.rows_used == 751
    assert c.delay_samples >= 1                       # lag 0 never searched in closed loop
    assert np.sign(c.gain) == np.sign(loop.gain)
    assert abs(c.gain - loop.gain) < 4 * c.gain_sd    # within the reported uncertainty
    assert c.gain_sd < 0.25 * abs(loop.gain)
    assert abs(c.time_constant_s - loop.time_constant_s) < 4 * c.time_constant_sd
    lo, hi = c.dead_time_ci95
    assert lo - 10.0 <= loop.dead_time_s <= hi + 10.0  # within a sample of the 95 % interval
    assert r.outputs[0].feedback == ("direct" if loop.gain > 0 else "reverse")
    # the written model is a valid model file with the disturbance model
    assert r.model.noise("PV").den[0] == 1.0 and len(r.model.noise("PV").den) >= 2


def test_estimate_is_scipy_joint_prediction_error_fit():
    df = pi_loop.simulate(pi_loop.PRESSURE, seed=3, setpoint_steps=True)
    r = model_from_data(df, "OP", "PV")
    c = r.channels[0]
    g = r.model.process("PV", "OP")
    b, f, a = ref.pem_ar_noise(df["PV"].to_numpy(), df["OP"].to_numpy(), r.outputs[0].noise_order,
                               c.numerator_length, c.delay_samples)
    assert np.allclose(g.num, b, rtol=1e-5, atol=1e-7)
    assert np.allclose(g.den, f, rtol=1e-5, atol=1e-7)
    assert np.allclose(r.model.noise("PV").den, a, rtol=1e-4, atol=1e-6)
    assert c.gain == pytest.approx(b.sum() / f.sum(), rel=1e-5)
    assert c.time_constant_s == pytest.approx(-10.0 / math.log(-f[1]), rel=1e-5)


def test_constant_input_is_not_identified():
    df = pi_loop.simulate(pi_loop.FLOW, seed=1)
    df["OP"] = 42.0
    with pytest.raises(NotIdentified, match="'OP' does not move"):
        model_from_data(df, ["OP"], ["PV"])


def test_input_without_effect_is_not_identified():
    rng = np.random.default_rng(5)
    df = pi_loop.simulate(pi_loop.FLOW, seed=2)
    df["OP"] = 50 + np.cumsum(rng.standard_normal(len(df))) * 0.1  # moves, but PV ignores it
    with pytest.raises(NotIdentified, match="not distinguishable from 0"):
        model_from_data(df, ["OP"], ["PV"])


def test_lag_zero_is_refused_under_feedback():
    df = pi_loop.simulate(pi_loop.FLOW, seed=1, setpoint_steps=True)
    with pytest.raises(ValueError, match="lag 0 cannot be searched"):
        model_from_data(df, ["OP"], ["PV"], min_delay=0)


def _channel(gain, sd):
    return ChannelSummary("PV", "OP", gain, sd, 30.0, 5.0, 10.0, (0.0, 20.0), 2, 1, True)


def test_sign_against_the_controller_needs_overwhelming_evidence():
    _check_verdict("PV", [_channel(1.0, 0.1)], action=1)            # agrees: fine
    with pytest.raises(NotIdentified, match="opposite to the controller"):
        _check_verdict("PV", [_channel(-1.0, 0.3)], action=1)        # z = 3.3 < SIGN_FLIP_Z
    _check_verdict("PV", [_channel(-1.0, 1.0 / (SIGN_FLIP_Z + 1))], action=1)  # overwhelming
    _check_verdict("PV", [_channel(-1.0, 0.3)], action=0)            # no feedback seen: no prior


def test_profile_interval_brackets_the_accepted_dead_times():
    # n log(V / V_best) with n = 100: 3 and 4 inside (<= 3.84), 2 and 5 bracket, 1 and 6 outside
    cost = {1.0: 2.0, 2.0: 1.05, 3.0: 1.0, 4.0: 1.03, 5.0: 1.2, 6.0: 3.0}
    assert _profile_interval(cost, 100) == (2.0, 5.0)


def test_cli_identify_then_compare_on_a_historian_length_record(tmp_path, capsys):
    df = pi_loop.simulate(pi_loop.PRESSURE, seed=4, setpoint_steps=True)
    data, model = tmp_path / "loop.csv", tmp_path / "model.json"
    io.save_data(data, df)
    assert main(["identify", str(data), "--inputs", "OP", "--outputs", "PV", "-o", str(model), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["sample_time_s"] == 10.0 and out["channels"][0]["gain"] < 0
    loaded = io.load_model(model)
    assert loaded.sample_time_s == 10.0 and loaded.process("PV", "OP") is not None
    # never silently overwritten
    assert main(["identify", str(data), "--inputs", "OP", "--outputs", "PV", "-o", str(model)]) == 2
    assert "exists" in capsys.readouterr().err
    # the identified model is a normal input for compare on the same 751 rows
    assert main(["compare", str(model), str(data)]) == 0
    assert "fit simulation" in capsys.readouterr().out


@pytest.mark.parametrize("args, message", [
    (["--inputs", "VALVE", "--outputs", "PV"], "no column 'VALVE'"),
    (["--inputs", "OP", "--outputs", "OP"], "both input and output"),
])
def test_cli_bad_columns_are_one_line_errors(tmp_path, capsys, args, message):
    data = tmp_path / "loop.csv"
    io.save_data(data, pi_loop.simulate(pi_loop.FLOW, seed=1).iloc[:200])
    assert main(["identify", str(data), *args, "-o", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_short_record_says_too_short_not_missing_values(tmp_path, capsys):
    data = tmp_path / "short.csv"
    io.save_data(data, pi_loop.simulate(pi_loop.FLOW, seed=1, rows=126))
    assert main(["identify", str(data), "--inputs", "OP", "--outputs", "PV", "-o", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert "too short: 126 rows (0.35 h); need at least 150" in err
    assert "missing" not in err


def test_miso_keeps_the_real_channels_and_leaves_out_an_input_without_effect():
    """Two outputs, two inputs (step-like test signals, open loop), Z does not depend on A: its
    channel must be left out (absent = zero in the model file), the others recovered."""
    import pandas as pd
    import scipy.signal as ss

    rng = np.random.default_rng(0)
    n = 900
    a = np.repeat(rng.standard_normal(n // 15), 15)
    b = np.repeat(rng.standard_normal(n // 20), 20)
    y = (ss.lfilter([0, 0, 0.3], [1, -0.7], a) + ss.lfilter([0, 0, 0, 0, -0.2], [1, -0.9], b)
         + ss.lfilter([1], [1, -0.8], 0.05 * rng.standard_normal(n)))
    z = ss.lfilter([0, 0.5], [1, -0.5], b) + 0.05 * rng.standard_normal(n)
    df = pd.DataFrame(dict(time=np.arange(n) * 5.0, A=a, B=b, Y=y, Z=z))
    r = model_from_data(df, ["A", "B"], ["Y", "Z"], max_dead_time_s=60.0)
    gains = {(c.output, c.input): c for c in r.channels}
    assert gains["Y", "A"].gain == pytest.approx(1.0, abs=4 * gains["Y", "A"].gain_sd)
    assert gains["Y", "B"].gain == pytest.approx(-2.0, abs=4 * gains["Y", "B"].gain_sd)
    assert gains["Y", "B"].delay_samples == 4 and gains["Z", "B"].delay_samples == 1
    assert not gains["Z", "A"].significant and r.model.process("Z", "A") is None
    assert r.model.process("Y", "A") is not None


def test_significance_threshold_grows_with_the_dead_times_searched():
    from mpmpp.channel_reading import significance_z

    assert significance_z(1) == pytest.approx(1.959964, abs=1e-6)
    assert 3.2 < significance_z(61) < 3.4


def test_cli_reads_the_controller_action_from_a_named_setpoint_column(tmp_path, capsys):
    df = pi_loop.simulate(pi_loop.PRESSURE, seed=6, setpoint_steps=True).rename(columns={"PV_sp": "SP"})
    data = tmp_path / "loop.csv"
    io.save_data(data, df)
    assert main(["identify", str(data), "--inputs", "OP", "--outputs", "PV", "--setpoints", "SP",
                 "-o", str(tmp_path / "m.json"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["outputs"][0]["feedback"] == "reverse"


def test_a_stretch_too_short_to_fit_is_left_out_and_said():
    """Missing values at rows 100-104: the first 100 rows are shorter than twice the criterion's
    start-up (2 x 69 rows), so they are left out with the missing ones."""
    df = pi_loop.simulate(pi_loop.PRESSURE, seed=8, setpoint_steps=True)
    df.loc[100:104, "PV"] = np.nan
    r = model_from_data(df, ["OP"], ["PV"])
    assert r.rows_used == 751 - 105 and r.skipped_rows == 105
    assert "105 rows skipped: missing values, time gaps or stretches between them too short to fit" in r.summary()


def _with_gaps(df, rows):
    """(df with the rows ``rows`` lost, OP and PV, the complete stretches [a, b) of the rows left,
    laid end to end). A lost input ends a stretch; a few lost PV samples alone would be
    interpolated (test_lost_outputs.py)."""
    gapped = df.copy()
    gapped.loc[rows, ["OP", "PV"]] = np.nan
    kept = np.flatnonzero(gapped["PV"].notna())
    breaks = np.flatnonzero(np.diff(kept) > 1) + 1
    bounds = np.r_[0, breaks, len(kept)]
    return gapped, kept, list(zip(bounds[:-1], bounds[1:]))


def test_every_stretch_between_missing_values_is_fitted_as_scipy_does_it():
    """Three stretches (PV missing at rows 200-204 and 480-482): the estimate is scipy's joint
    prediction-error fit over the three, each filtered from rest, and its covariance the
    finite-difference one of that criterion."""
    df = pi_loop.simulate(pi_loop.PRESSURE, seed=3, setpoint_steps=True)
    gapped, kept, stretches = _with_gaps(df, [*range(200, 205), *range(480, 483)])
    r = model_from_data(gapped, "OP", "PV")
    assert r.rows_used == 751 - 8 and r.skipped_rows == 8
    c = r.channels[0]
    pv, op = df["PV"].to_numpy()[kept], df["OP"].to_numpy()[kept]
    b, f, a = ref.pem_ar_noise(pv, op, r.outputs[0].noise_order, c.numerator_length, c.delay_samples,
                               stretches=stretches)
    g = r.model.process("PV", "OP")
    assert np.allclose(g.num, b, rtol=1e-5, atol=1e-7)
    assert np.allclose(g.den, f, rtol=1e-5, atol=1e-7)
    assert np.allclose(r.model.noise("PV").den, a, rtol=1e-4, atol=1e-6)
    # the same fit as one stretch is another fit: the gaps matter
    b1, _, _ = ref.pem_ar_noise(pv, op, r.outputs[0].noise_order, c.numerator_length, c.delay_samples)
    assert not np.allclose(b1, b, rtol=1e-3)

    st = Stretches([q - p for p, q in stretches])
    y, U = pv - pv.mean(), (op - op.mean())[:, None]
    cls = SELF_REGULATING
    cand = search.refine(y, U, search.fit_candidate(y, U, 2, [4], [2], cls, 69, st), cls, 69, st)
    cov = search.joint_covariance(y, U, cand, st)
    tf = cand.tf[0]
    expected = ref.pem_ar_noise_covariance(pv, op, 2, 2, 4, np.asarray(tf.num), np.asarray(tf.den),
                                           np.r_[1.0, cand.a], stretches=stretches)
    assert np.allclose(cov, expected, rtol=1e-4, atol=1e-9 * np.abs(expected).max())


def test_a_record_with_no_long_stretch_is_identified_from_its_many_short_ones():
    """Every 140th row of a 6 h record lost: no stretch reaches the 150 rows a record
    needs, but 15 stretches of 139 rows hold 2,085 rows, and the loop is identified from them
    (the longest stretch alone was refused)."""
    df = pi_loop.simulate(pi_loop.PRESSURE, seed=12, rows=2160, setpoint_steps=True)
    gapped, _, stretches = _with_gaps(df, list(range(139, 2160, 140)))
    assert max(b - a for a, b in stretches) < 150
    r = model_from_data(gapped, ["OP"], ["PV"])
    c, = r.channels
    loop = pi_loop.PRESSURE
    assert r.rows_used == 15 * 139          # the last 60 rows are too short a stretch
    assert abs(c.gain - loop.gain) < 4 * c.gain_sd and c.gain_sd < 0.15 * abs(loop.gain)
    assert abs(c.time_constant_s - loop.time_constant_s) < 4 * c.time_constant_sd
    lo, hi = c.dead_time_ci95
    assert lo - 10.0 <= loop.dead_time_s <= hi + 10.0


def test_scattered_missing_values_are_named_not_called_a_short_record(tmp_path, capsys):
    """A PV missing in every seventh row leaves no stretch long enough: the message says so and
    counts the missing values per column; it used to read "too short: 6 rows (0.017 h)" for a
    751-row file."""
    df = pi_loop.simulate(pi_loop.PRESSURE, seed=8)
    df.loc[::7, "PV"] = np.nan
    data = tmp_path / "sparse.csv"
    io.save_data(data, df)
    assert main(["identify", str(data), "--inputs", "OP", "--outputs", "PV", "-o", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert ("data: the stretches of at least 138 rows without missing values or time gaps hold 0 of 751 rows, "
            "need 150 (missing values: PV 108)") in err
    assert err.count("\n") == 1 and "too short" not in err
    assert not (tmp_path / "m.json").exists()


def test_rows_a_historian_left_out_split_the_record_like_missing_values():
    """A time gap (rows absent, a whole number of samples) cuts the record as missing rows do;
    the fit is the same as with those rows present but missing."""
    df = pi_loop.simulate(pi_loop.PRESSURE, seed=8, setpoint_steps=True)
    gapped = df.drop(index=range(100, 105)).reset_index(drop=True)
    missing = df.copy()
    missing.loc[100:104, ["OP", "PV"]] = np.nan
    r, m = model_from_data(gapped, ["OP"], ["PV"]), model_from_data(missing, ["OP"], ["PV"])
    assert r.rows_used == m.rows_used == 751 - 105 and r.skipped_rows == 100
    assert r.channels[0].gain == m.channels[0].gain and r.channels[0].dead_time_s == m.channels[0].dead_time_s


def test_a_step_that_is_no_whole_number_of_samples_is_an_error_naming_the_row():
    df = pi_loop.simulate(pi_loop.PRESSURE, seed=8)
    df.loc[200:, "time"] += 4.0
    with pytest.raises(ValueError, match=r"not evenly spaced \(step 14 s at row 200, typical 10 s"):
        model_from_data(df, ["OP"], ["PV"])


def test_timestamps_in_the_time_column_are_a_one_line_error_not_nanoseconds():
    """A data frame's time column of datetime64 would read as nanoseconds (a 10 s sample time
    of 1e10): every entry point says which column and what it needs."""
    from mpmpp.detect import detect
    from mpmpp.diagnose import diagnose

    df = pi_loop.simulate(pi_loop.PRESSURE, seed=8, setpoint_steps=True)
    model = model_from_data(df, ["OP"], ["PV"]).model
    df["time"] = pd.Timestamp("2024-03-01 06:00") + pd.to_timedelta(df["time"], unit="s")
    for call in (lambda: model_from_data(df, ["OP"], ["PV"]), lambda: diagnose(model, df),
                 lambda: detect(model, df)):
        with pytest.raises(ValueError, match="column 'time' holds timestamps"):
            call()


def test_joint_covariance_is_the_finite_difference_one():
    df = pi_loop.simulate(pi_loop.FLOW, seed=4)
    y = df["PV"].to_numpy() - df["PV"].mean()
    U = df[["OP"]].to_numpy() - df["OP"].mean()
    cls = SELF_REGULATING
    c = search.refine(y, U, search.fit_candidate(y, U, 2, [2], [1], cls, 60), cls, 60)
    cov = search.joint_covariance(y, U, c)
    g = c.tf[0]
    expected = ref.pem_ar_noise_covariance(df["PV"].to_numpy(), df["OP"].to_numpy(), 2, 1, 2,
                                           np.asarray(g.num), np.asarray(g.den), np.r_[1.0, c.a])
    assert np.allclose(cov, expected, rtol=1e-4, atol=1e-9 * np.abs(expected).max())


def test_dead_time_between_samples_is_fitted_not_rounded():
    """A 12 s dead time at 10 s sampling (1.2 samples) on a nearly noise-free loop: theta and tau
    as the exact ZOH discretisation says, not theta rounded to 10 s with tau absorbing the rest."""
    from dataclasses import replace

    loop = replace(pi_loop.FLOW, noise_sd=1e-4)
    r = model_from_data(pi_loop.simulate(loop, seed=1, setpoint_steps=True, step_size=1.0), ["OP"], ["PV"])
    c, = r.channels
    assert c.numerator_length == 2 and c.delay_samples == 2
    assert c.dead_time_s == pytest.approx(12.0, abs=0.05)
    assert c.time_constant_s == pytest.approx(25.0, rel=0.01)
    assert c.gain == pytest.approx(1.6, rel=0.01)


def test_fractional_dead_time_is_not_rounded_down_at_routine_noise():
    """The same loop at its routine noise, seeds 1-6: BIC counts the dead time as one parameter,
    so the fraction of a sample is kept (read as 10 s on every seed when the second numerator term
    was priced as an extra parameter)."""
    fits = [model_from_data(pi_loop.simulate(pi_loop.FLOW, seed=s, setpoint_steps=True), ["OP"], ["PV"]).channels[0]
            for s in range(1, 7)]
    assert abs(np.mean([c.dead_time_s for c in fits]) - 12.0) < 1.0
    assert sum(c.numerator_length == 2 for c in fits) >= 4


def _zoh_integrator_with_lag(gain, tau, ts):
    """SciPy's ZOH discretisation of K / (s (tau s + 1)): (b, a) of q^-1 (b0 + b1 q^-1) /
    ((1 - q^-1) (1 - a q^-1))."""
    import scipy.signal as ss

    num, den, _ = ss.cont2discrete(([gain], [tau, 1.0, 0.0]), ts, method="zoh")
    return np.ravel(num)[1:], float(next(r for r in np.roots(den) if abs(r - 1.0) > 1e-6).real)


def test_integrating_channel_parameters_invert_the_zoh():
    """K e^(-theta s) / (s (tau s + 1)) at a whole number of samples of dead time: SciPy's ZOH
    coefficients give back K, tau and theta (the first-moment dead time is exact); without a lag
    the dead time between samples is exact too."""
    from mpmpp.process_class import INTEGRATING_LAG

    b, a = _zoh_integrator_with_lag(0.004, 60.0, 10.0)
    k, tau, theta = INTEGRATING_LAG.reading(b, np.r_[1.0, -a], 3 + 1, 10.0)
    assert (k, tau, theta) == pytest.approx((0.004, 60.0, 30.0), rel=1e-9)
    # pure integrator, theta = 15 s = 1.5 samples: b0 = K Ts (1 - 0.5), b1 = K Ts 0.5 from q^-2
    assert INTEGRATING.reading(np.array([0.02, 0.02]), np.ones(1), 2, 10.0) == pytest.approx((0.004, 0.0, 15.0))


@pytest.mark.parametrize("tau, theta", [(60.0, 30.0), (0.0, 15.0)])
def test_reference_integrating_loop_is_the_exact_zoh(tau, theta):
    """The study's integrating process (pi_loop, sub-grid simulation) against SciPy's ZOH."""
    import scipy.signal as ss

    loop = pi_loop.Loop("tank", 0.004, tau, theta, 0.01, 0.8, integrating=True)
    process = pi_loop._Integrator(loop, 10.0)
    u = np.random.default_rng(0).standard_normal(60)
    level = np.array([process.step(x) for x in u])     # level at the end of each held sample
    if tau > 0:
        b, a = _zoh_integrator_with_lag(loop.gain, tau, 10.0)
        expected = ss.lfilter(np.r_[np.zeros(4), b], np.convolve([1.0, -1.0], [1.0, -a]), u)
    else:
        expected = ss.lfilter([0.0, 0.0, 0.02, 0.02], [1.0, -1.0], u)
    assert np.allclose(level[:-1], expected[1:], rtol=1e-9, atol=1e-12)


def test_integrating_level_loop_is_identified_as_integrating():
    """A level under PI control (pure integrator, rate gain 0.004 %/s per %, dead time 15 s,
    inflow disturbance) with setpoint steps: the integrating class wins, the rate gain and dead
    time are recovered within their uncertainty, and the model file's channel has its pole at 1."""
    loop = pi_loop.TANK
    df = pi_loop.simulate(loop, seed=3, setpoint_steps=True, step_size=0.5)
    r = model_from_data(df, ["OP"], ["PV"])
    c, = r.channels
    assert r.outputs[0].process_class == "integrating plus dead time" and c.integrating
    assert abs(c.gain - loop.gain) < 4 * c.gain_sd and c.gain_sd < 0.25 * loop.gain
    assert c.time_constant_s == 0.0
    lo, hi = c.dead_time_ci95
    assert lo - 10.0 <= loop.dead_time_s <= hi + 10.0
    g = r.model.process("PV", "OP")
    assert np.asarray(g.den) == pytest.approx([1.0, -1.0]) and np.sum(g.num) == pytest.approx(c.gain * 10.0)
    assert "integrating, rate gain" in r.summary() and "per s" in r.summary()
    assert r.outputs[0].class_open is None and "class is open" not in r.summary()
    # the same fit as SciPy's joint prediction-error fit of the differenced level
    y = df["PV"].to_numpy() - df["PV"].mean()
    dy = np.r_[0.0, np.diff(y)]
    b, f, a = ref.pem_ar_noise(dy - dy.mean(), df["OP"].to_numpy(), r.outputs[0].noise_order,
                               c.numerator_length, c.delay_samples, nf=0)
    assert f == pytest.approx([1.0])
    assert np.allclose(g.num, b, rtol=1e-5, atol=1e-9)


@pytest.mark.parametrize("seed", [1, 2])
def test_self_regulating_flow_loop_is_not_called_integrating(seed):
    """Routine data of a flow loop fit an integrator's one-step errors about as well; counting the
    integrator as first order's tau -> infinity limit keeps the first-order class."""
    r = model_from_data(pi_loop.simulate(pi_loop.FLOW, seed=seed), ["OP"], ["PV"])
    assert r.outputs[0].process_class == "first order plus dead time" and not r.channels[0].integrating


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_integrator_chosen_over_a_better_settling_fit_says_the_class_is_open(seed):
    """A routine pressure-like loop (tau 120 s, 2 h at 10 s) is called integrating: first order
    plus dead time fits it better by 12-17 in BIC but its gain is not determined, while the
    integrator's rate is. The summary and the JSON say the class is open and what first order
    reads, near the truth (gain -2.5, 120 s)."""
    r = model_from_data(pi_loop.simulate(pi_loop.PRESSURE, seed=seed), ["OP"], ["PV"])
    o = r.outputs[0]
    assert r.channels[0].integrating and o.class_open is not None
    margin = float(o.class_open.split("better by ")[1].split(" in BIC")[0])
    assert 12.0 <= margin <= 17.0
    assert "does not determine its gain (-" in o.class_open and "--process self-regulating" in o.class_open
    assert "    the class is open: first order plus dead time" in r.summary()
    assert r.to_dict()["outputs"][0]["class_open"] == o.class_open


def test_settling_fit_is_not_named_when_first_order_is_chosen():
    """The flow loop's routine record: first order is chosen, nothing is open."""
    r = model_from_data(pi_loop.simulate(pi_loop.FLOW, seed=1), ["OP"], ["PV"])
    assert not r.channels[0].integrating and r.outputs[0].class_open is None


def test_cli_integrating_level_json_and_forced_class(tmp_path, capsys):
    data, model = tmp_path / "level.csv", tmp_path / "model.json"
    io.save_data(data, pi_loop.simulate(pi_loop.TANK, seed=2, setpoint_steps=True, step_size=0.5))
    assert main(["identify", str(data), "--inputs", "OP", "--outputs", "PV", "-o", str(model), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    ch, = out["channels"]
    assert ch["integrating"] is True and ch["time_constant_sd"] is None
    assert out["outputs"][0]["process_class"] == "integrating plus dead time"
    assert io.load_model(model).process("PV", "OP").den[-1] == pytest.approx(-1.0)
    # forced to first order, the pole goes to 1 and the gain is lost in its uncertainty
    assert main(["identify", str(data), "--inputs", "OP", "--outputs", "PV", "-o", str(model), "--force",
                 "--process", "self-regulating"]) == 2
    assert "not distinguishable from 0" in capsys.readouterr().err


def test_class_choice_prefers_first_order_unless_clearly_beaten_or_at_its_boundary():
    from types import SimpleNamespace

    from mpmpp.class_choice import CLASS_MARGIN, ClassFit, choose_class

    def fit(cls, bic, significant, tau=30.0, dead=10.0):
        c = ChannelSummary("PV", "OP", 1.0, 0.1, tau, 5.0, dead, (0.0, 20.0), 2, 1, significant)
        return ClassFit(cls, SimpleNamespace(bic=bic), [c])

    record, ts = 7500.0, 10.0
    # integrator better, but by less than the margin: first order kept
    assert choose_class([fit(SELF_REGULATING, 0.0, True), fit(INTEGRATING, -CLASS_MARGIN + 0.5, True)],
                        record, ts)[0] is SELF_REGULATING
    assert choose_class([fit(SELF_REGULATING, 0.0, True), fit(INTEGRATING, -CLASS_MARGIN - 0.5, True)],
                        record, ts)[0] is INTEGRATING
    # first order identifies nothing: the integrator replaces it at first order's boundary, or
    # when it has a dead time of a sample or more; without one it does not (and the verdict refuses)
    assert choose_class([fit(SELF_REGULATING, 0.0, False, tau=1e5), fit(INTEGRATING, 2.0, True, dead=0.0)],
                        record, ts)[0] is INTEGRATING
    assert choose_class([fit(SELF_REGULATING, 0.0, False, tau=400.0), fit(INTEGRATING, 2.0, True)],
                        record, ts)[0] is INTEGRATING
    assert choose_class([fit(SELF_REGULATING, 0.0, False, tau=400.0), fit(INTEGRATING, 2.0, True, dead=5.0)],
                        record, ts)[0] is SELF_REGULATING
    # forced integrating classes: plain BIC
    assert choose_class([fit(INTEGRATING, 1.0, True), fit(INTEGRATING, 0.0, True)], record, ts)[1].bic == 0.0


def test_threads_do_not_change_the_result():
    df = pi_loop.simulate(pi_loop.PRESSURE, seed=5, setpoint_steps=True)
    one = model_from_data(df, ["OP"], ["PV"], workers=1).to_dict()
    three = model_from_data(df, ["OP"], ["PV"], workers=3).to_dict()
    assert one == three


def _cpp_level_loop(seed, n=1500):
    """A level (0.05 PV units per s per % OP, 3 samples' delay at 1 s) under PI control in the
    project's C++ closed-loop simulator, setpoint steps every 200 s and an integrated AR(1)
    inflow disturbance: a generator independent of pi_loop."""
    import pandas as pd
    import scipy.signal as ss

    from mpmpp.stiction.loop import Process, simulate_pi_loop

    rng = np.random.default_rng(seed)
    disturbance = np.cumsum(ss.lfilter([1.0], [1.0, -0.7], 0.01 * rng.standard_normal(n)))
    sp = np.where((np.arange(n) // 200) % 2 == 1, 1.0, 0.0)
    r = simulate_pi_loop(Process(b=(0.05,), a=(1.0, -1.0), delay=3), 2.0, 40.0, n,
                         disturbance=disturbance, setpoint=sp)
    return pd.DataFrame(dict(time=np.arange(n) * 1.0, OP=r["op"], PV=r["pv"], PV_sp=r["sp"]))


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_level_from_the_cpp_simulator_is_integrating_with_its_rate_gain(seed):
    r = model_from_data(_cpp_level_loop(seed), ["OP"], ["PV"], max_dead_time_s=40)
    c, = r.channels
    assert c.integrating and c.time_constant_s == 0.0
    assert abs(c.gain - 0.05) < 4 * c.gain_sd
    assert c.dead_time_s == pytest.approx(2.0, abs=0.1)   # q^-3 at 1 s: 2 s after the hold


def test_integrating_class_taken_when_first_order_loses_its_gain():
    """Seed 1: a first-order fit with a 200 s lag scores better than the integrator but its gain is
    not determined; the integrator's rate is, through a dead time of its own, so it is taken."""
    r = model_from_data(_cpp_level_loop(1), ["OP"], ["PV"], max_dead_time_s=40)
    ch, = r.channels
    assert ch.integrating and ch.gain == pytest.approx(0.05, rel=0.15) and ch.dead_time_s >= 1.0


def test_refusal_names_the_integrating_reading_when_the_class_is_open():
    from types import SimpleNamespace

    from mpmpp.class_choice import ClassFit, integrating_alternative

    def fit(cls, significant):
        c = ChannelSummary("PV", "OP", 0.05, 0.002, 0.0, float("nan"), 0.0, (0.0, 1.0), 1, 1, significant, True)
        return ClassFit(cls, SimpleNamespace(bic=0.0), [c])

    text = integrating_alternative([fit(SELF_REGULATING, False), fit(INTEGRATING, True)], SELF_REGULATING)
    assert text.startswith("; as an integrating process: rate gain 0.05 +- 0.002 per s from 'OP', dead time 0 s")


def test_identified_level_model_goes_through_diagnose(tmp_path, capsys):
    """identify then diagnose on a 751-row level record: the integrating channel (pole at 1) is a
    normal input for diagnose, and the right model gives no finding."""
    data, model = tmp_path / "level.csv", tmp_path / "model.json"
    io.save_data(data, pi_loop.simulate(pi_loop.TANK, seed=3, setpoint_steps=True, step_size=0.5))
    assert main(["identify", str(data), "--inputs", "OP", "--outputs", "PV", "-o", str(model)]) == 0
    capsys.readouterr()
    assert main(["diagnose", str(model), str(data)]) == 0
    assert "no finding" in capsys.readouterr().out


def test_lag_class_is_skipped_only_when_the_output_clearly_settles():
    from types import SimpleNamespace

    from mpmpp.class_choice import ClassFit, lag_worth_searching

    def fit(cls, bic):
        return ClassFit(cls, SimpleNamespace(bic=bic), [])

    assert lag_worth_searching([fit(SELF_REGULATING, 0.0), fit(INTEGRATING, search.PRUNE - 1.0)])
    assert not lag_worth_searching([fit(SELF_REGULATING, 0.0), fit(INTEGRATING, search.PRUNE + 1.0)])
    assert lag_worth_searching([fit(INTEGRATING, 5.0)])  # forced integrating classes


def test_joint_covariance_of_an_integrating_channel_is_the_finite_difference_one():
    """The pure integrator's differenced fit (FIR channel, no denominator parameter)."""

    df = pi_loop.simulate(pi_loop.TANK, seed=4, setpoint_steps=True, step_size=0.5)
    dy = search.differenced(df["PV"].to_numpy() - df["PV"].mean(), Stretches([len(df)]))
    U = df[["OP"]].to_numpy() - df["OP"].mean()
    cls = INTEGRATING
    c = search.refine(dy, U, search.fit_candidate(dy, U, 2, [2], [2], cls, 60), cls, 60)
    cov = search.joint_covariance(dy, U, c)
    g = c.tf[0]
    expected = ref.pem_ar_noise_covariance(dy, df["OP"].to_numpy(), 2, 2, 2, np.asarray(g.num), np.ones(1),
                                           np.r_[1.0, c.a])
    assert cov.shape == (4, 4)
    assert np.allclose(cov, expected, rtol=1e-4, atol=1e-9 * np.abs(expected).max())


def test_no_process_class_is_a_value_error():
    with pytest.raises(ValueError, match="classes: give one or more ProcessClass"):
        model_from_data(pi_loop.simulate(pi_loop.FLOW, seed=1, rows=200), ["OP"], ["PV"], classes=())


def test_level_with_transmitter_noise_gets_a_stationary_disturbance_model():
    """A tank whose disturbance is at the output (stationary AR(1), not an inflow): the integrating
    class with the output disturbance wins, fitted as the level against the integrated input; its
    noise model has no unit root, and the fit is SciPy's joint fit of that structure."""
    loop = pi_loop.TANK_NOISY
    df = pi_loop.simulate(loop, seed=2, setpoint_steps=True, step_size=0.5)
    r = model_from_data(df, ["OP"], ["PV"])
    c, = r.channels
    assert r.outputs[0].process_class == "integrating plus dead time, disturbance at the output"
    assert c.integrating and abs(c.gain - loop.gain) < 4 * c.gain_sd
    assert np.max(np.abs(np.roots(r.model.noise("PV").den))) < 0.95
    assert np.asarray(r.model.process("PV", "OP").den) == pytest.approx([1.0, -1.0])
    u = df["OP"].to_numpy()
    b, f, a = ref.pem_ar_noise(df["PV"].to_numpy(), np.cumsum(u - u.mean()), r.outputs[0].noise_order,
                               c.numerator_length, c.delay_samples, nf=0)
    assert np.allclose(r.model.process("PV", "OP").num, b, rtol=1e-5, atol=1e-9)
    assert np.allclose(r.model.noise("PV").den, a, rtol=1e-4, atol=1e-6)


def test_integrating_disturbance_is_an_inflow_unless_the_output_form_wins_clearly():
    from types import SimpleNamespace

    from mpmpp.class_choice import OUTPUT_NOISE_MARGIN, ClassFit, choose_class
    from mpmpp.process_class import INTEGRATING_OUTPUT_NOISE

    def fit(cls, bic, significant=True):
        c = ChannelSummary("PV", "OP", 1.0, 0.1, 0.0, float("nan"), 10.0, (0.0, 20.0), 2, 1, significant)
        return ClassFit(cls, SimpleNamespace(bic=bic), [c])

    first = fit(SELF_REGULATING, 0.0, significant=False)
    close = [first, fit(INTEGRATING, -5.0), fit(INTEGRATING_OUTPUT_NOISE, -5.0 - OUTPUT_NOISE_MARGIN + 1)]
    clear = [first, fit(INTEGRATING, -5.0), fit(INTEGRATING_OUTPUT_NOISE, -5.0 - OUTPUT_NOISE_MARGIN - 1)]
    assert choose_class(close, 7500.0, 10.0)[0] is INTEGRATING
    assert choose_class(clear, 7500.0, 10.0)[0] is INTEGRATING_OUTPUT_NOISE
    # no identified inflow form: the output form stands on its own
    alone = [first, fit(INTEGRATING, -5.0, significant=False), fit(INTEGRATING_OUTPUT_NOISE, -6.0)]
    assert choose_class(alone, 7500.0, 10.0)[0] is INTEGRATING_OUTPUT_NOISE


def test_an_input_only_its_controller_moves_is_flagged():
    """A PI run at the sample rate on a record without setpoint moves: the OP is an exact law of
    the PV, the record does not determine the process (the stiction study's flow loop, gain 1,
    comes out at about 0.26 +- 0.04), and every channel says so; a setpoint step, or an OP that
    something besides the controller moves, clears the flag."""
    import stiction_benchmark as sb
    from mpmpp.controller_action import controller_law_exact
    from mpmpp.stiction.loop import simulate_pi_loop

    flow = next(d for d in sb.TUNING if d.name == "flow")
    rec = sb.make_record("tuning", flow, "linear", 0.0, 0.0, 8800)
    frame = pd.DataFrame({"time": 10.0 * np.arange(751), "OP": rec["op"], "PV": rec["pv"] + 20.0})
    (c,) = model_from_data(frame, ["OP"], ["PV"]).channels
    assert c.unexcited and c.uncertain and "follows the controller exactly" in c.describe()
    assert abs(c.gain - 1.0) > 4 * c.gain_sd        # why: the reported spread is no guide here
    assert controller_law_exact(rec["op"], rec["pv"], None)
    rng = np.random.default_rng(1)
    assert not controller_law_exact(rec["op"] + 1e-3 * rng.standard_normal(751), rec["pv"], None)
    sp = np.where(np.arange(751) < 375, 0.0, 0.5)
    stepped = simulate_pi_loop(flow.process, flow.kc, flow.ti, 751, setpoint=sp,
                               disturbance=0.3 * rng.standard_normal(751))
    # the law of the control error is exact, but the setpoint moves the OP from outside
    assert controller_law_exact(stepped["op"], stepped["pv"] - stepped["sp"], None)
    assert not controller_law_exact(stepped["op"], stepped["pv"], stepped["sp"])
    frame = pd.DataFrame({"time": 10.0 * np.arange(751), "OP": stepped["op"], "PV": stepped["pv"] + 20.0,
                          "SP": stepped["sp"] + 20.0})
    (c,) = model_from_data(frame, ["OP"], ["PV"], setpoints=["SP"]).channels
    assert not c.unexcited


def test_the_controller_action_is_read_within_stretches_not_across_a_gap():
    """A direct-acting PI law, du = 0.5 de + 0.01 e, in two stretches: across the gap the error
    went from about +5 to -5 while the OP was moved up by hand. Laid end to end, that one
    difference (de -10, du +100) outweighs 798 within the stretches and reverses the sign;
    left out, the action is read right."""
    from mpmpp.controller_action import controller_action

    rng = np.random.default_rng(2)
    pieces = []
    for level, bias in ((5.0, 0.0), (-5.0, 100.0)):
        e = level + np.cumsum(rng.standard_normal(400)) * 0.05
        u = bias + np.cumsum(np.r_[0.0, 0.5 * np.diff(e) + 0.01 * e[1:]])
        pieces.append((u + 0.01 * rng.standard_normal(400), -e))   # pv = sp - e with sp = 0
    u, pv = np.concatenate([p[0] for p in pieces]), np.concatenate([p[1] for p in pieces])
    assert controller_action(u, pv, np.zeros(800), starts=[400]) == 1
    assert controller_action(u, pv, np.zeros(800)) == -1


def test_a_wandering_disturbance_gets_a_moving_average_root_and_the_scipy_fit_at_it():
    """A nearly integrated disturbance (the families' `wander` colour, IMA(1,1)-like) needs
    H = (1 - c q^-1) / A, which no short AR holds (docs/identify.md "A wandering disturbance").
    The root comes from MA_ROOTS; at it, the estimate is SciPy's joint prediction-error fit of
    the data through 1 / (1 - c q^-1). An AR(1) disturbance keeps H = 1 / A."""
    import scipy.signal as ss

    from mpmpp import families
    from mpmpp.diagnosis_study import simulate
    from mpmpp.model_identification import MA_ROOTS

    for seed in (0, 2):
        spec, _ = families.family("pi_siso_wander").draw(seed, 6 * 3600.0, "none")
        df = simulate(spec)
        r = model_from_data(df, ["u1"], ["y1"])
        h, g, c = r.model.noise("y1"), r.model.process("y1", "u1"), r.channels[0]
        assert len(h.num) == 2 and -h.num[1] in MA_ROOTS[1:]
        smooth = [ss.lfilter([1.0], [1.0, h.num[1]], df[col].to_numpy() - df[col].mean()) for col in ("y1", "u1")]
        b, f, a = ref.pem_ar_noise(*smooth, r.outputs[0].noise_order, c.numerator_length, c.delay_samples)
        # the reference removes the filtered data's mean, mpmpp the raw data's: agreement to 1e-3
        assert sum(g.num) / sum(g.den) == pytest.approx(b.sum() / f.sum(), rel=1e-3)
        assert np.allclose(g.den, f, rtol=1e-3) and np.allclose(g.num, b, atol=1e-3)
        assert np.allclose(h.den, a, atol=1e-3)
    r = model_from_data(pi_loop.simulate(pi_loop.FLOW, seed=11, setpoint_steps=True), ["OP"], ["PV"])
    assert list(r.model.noise("PV").num) == [1.0]
