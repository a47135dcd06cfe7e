"""diagnose on single PI loops as a historian gives them: 2 h at 10 s (751 rows), the model
identified from the same data (`mpmpp identify`), or a hand-written one."""
import json

import numpy as np
import pandas as pd
import pytest

import mpmpp
from mpmpp.cli import main
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose
from mpmpp.diagnose.pipeline import record_lengths
from mpmpp.identify import model_from_data
from mpmpp.record_length import scaled_rows

import pi_loop


def test_record_lengths_scale_with_a_short_record():
    # 751 rows at 10 s: a third of the record per segment, an eighth per block
    lengths = record_lengths(751, 10.0)
    assert (lengths.min_segment, lengths.block) == (250, 93)
    # a long record keeps the preferred 1 h
    assert (record_lengths(6 * 360, 10.0).min_segment, record_lengths(8 * 360, 10.0).block) == (360, 360)
    assert record_lengths(751, 10.0, min_segment_s=1200.0).min_segment == scaled_rows(751, 10.0, 1200.0, 3, 50)
    with pytest.raises(ValueError, match=r"too short: 126 rows \(0.35 h\); need at least 150"):
        record_lengths(126, 10.0)


@pytest.mark.parametrize("seed", [1, 2])
def test_identify_then_diagnose_a_historian_record(tmp_path, capsys, seed):
    """The user's path: `mpmpp identify` then `mpmpp diagnose` on a linear 2 h loop record.
    The model was made from these data, so the honest answer is no finding."""
    data = pi_loop.simulate(pi_loop.FLOW, seed, setpoint_steps=True)
    csv, model = tmp_path / "loop.csv", tmp_path / "model.json"
    data.to_csv(csv, index=False)
    assert main(["identify", str(csv), "--inputs", "OP", "--outputs", "PV", "-o", str(model)]) == 0
    capsys.readouterr()
    assert main(["diagnose", str(model), str(csv), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["findings"] == []


def test_wrong_hand_written_gain_is_found_on_a_2h_record():
    """A hand-written FOPTD model with half the process gain: a gain finding with ratio near 2
    present throughout, found with the scaled segments (the fixed 1 h ones refused 751 rows)."""
    loop = pi_loop.FLOW
    data = pi_loop.simulate(loop, 3, setpoint_steps=True)
    a, b0, b1, d = pi_loop.foptd_coefficients(loop, 10.0)
    half = mpmpp.Model("half gain", 10.0, ["OP"], ["PV"],
                       {"PV": {"OP": mpmpp.TransferFunction([0.5 * b0, 0.5 * b1], [1.0, -a], d)}})
    res = diagnose(half, data)
    assert res.findings and res.findings[0].effect == "gain"
    assert 1.6 < res.findings[0].estimate["gain_ratio"] < 2.5
    assert res.findings[0].error_after < res.findings[0].error_before


def _hand_written_model(loop, gain_factor=1.0):
    """The FOPTD model a user writes for ``loop`` (its gain times ``gain_factor``), no noise model."""
    g = mpmpp.TransferFunction.from_foptd(loop.gain * gain_factor, loop.time_constant_s, loop.dead_time_s, 10.0)
    return mpmpp.Model("hand-written", 10.0, ["OP"], ["PV"], {"PV": {"OP": g}})


@pytest.mark.parametrize("loop, seed", [(pi_loop.FLOW, 1), (pi_loop.PRESSURE, 1), (pi_loop.LEVEL, 3)])
def test_doubled_hand_written_gain_is_found_on_a_2h_record(loop, seed):
    """A hand-written FOPTD model with twice the process gain, 2 h with setpoint steps: a gain
    finding from the first row with a ratio near 0.5. Before the short-record check of
    pipeline._without_unconfirmed_standing_changes each was withheld: the process part of each
    half, fitted on two blocks, rose in one of them."""
    res = diagnose(_hand_written_model(loop, 2.0), pi_loop.simulate(loop, seed, setpoint_steps=True))
    top = res.findings[0]
    assert (top.effect, top.onset_s) == ("gain", 0.0)
    assert 0.38 < top.estimate["gain_ratio"] < 0.65
    assert not [n for n in res.notes if "withheld" in n]


def test_a_wrong_gain_stays_beside_an_unsure_valve_verdict(earlier_valve_fit):
    """A 2 h flow loop with a linear valve (seed 8) on which the valve fit says stick-slip at a
    confidence of about 0.6, as it does on about a tenth of linear loops. With a hand-written model
    of half the plant's gain, the gain finding used to be replaced by the valve finding; a valve
    does not change the process, so the model's error is reported first and the valve beside it.
    With the right model the valve finding stands alone (nothing to report beside it). The valve
    fit before 2026-12-03 gave this verdict; refined and with its map refitted it calls this loop
    linear (rightly), so the test keeps the earlier fit: it is about what diagnose does with an
    unsure valve verdict."""
    loop = pi_loop.FLOW
    data = pi_loop.simulate(loop, 8, setpoint_steps=True)
    res = diagnose(_hand_written_model(loop, 0.5), data)
    assert [f.effect for f in res.findings] == ["gain", "input_nonlinearity"]
    gain, valve = res.findings
    assert gain.onset_s == 0.0 and 1.6 < gain.estimate["gain_ratio"] < 2.5
    assert valve.confidence < 0.9
    right = diagnose(_hand_written_model(loop), data)
    assert [f.effect for f in right.findings if f.effect in PROCESS_EFFECTS] == ["input_nonlinearity"]


@pytest.mark.parametrize("loop", pi_loop.LOOPS)
def test_right_hand_written_model_gets_no_process_finding_on_a_2h_record(loop):
    for seed in (1, 2, 3):
        res = diagnose(_hand_written_model(loop), pi_loop.simulate(loop, seed, setpoint_steps=True))
        assert not [f for f in res.findings if f.effect in PROCESS_EFFECTS], (loop.name, seed)


def test_a_deadband_fit_of_the_valve_is_reported_not_a_crash(monkeypatch, earlier_valve_fit):
    """A 2 h flow loop whose plant gain halves an hour in, the model's gain half the plant's: the
    valve fit with N_Y PV lags only found a positioner deadband here, which has a width and no S
    or J, and diagnose raised KeyError 'S' on it. (With LONG_N_Y lags as well the fit finds no
    valve on this linear loop, rightly; the short structure and the valve fit before 2026-12-03
    keep the record a deadband case.)"""
    from mpmpp.stiction import hammerstein

    monkeypatch.setattr(hammerstein, "LONG_N_Y", hammerstein.N_Y)
    loop = pi_loop.FLOW
    data = pi_loop.simulate(loop, 3, setpoint_steps=True, gain_change=(360, 0.5))
    res = diagnose(_hand_written_model(loop, 0.5), data)
    [valve] = [f for f in res.findings if f.effect == "input_nonlinearity"]
    assert valve.estimate["kind"] == valve.estimate["actuator"]["kind"] == "deadband"
    assert valve.estimate["width"] == valve.estimate["actuator"]["width"] > 0
    assert "has a deadband" in valve.explanation and "S =" not in valve.explanation


def test_short_record_says_too_short(tmp_path, capsys):
    data = pi_loop.simulate(pi_loop.FLOW, 1, rows=126)
    csv, model = tmp_path / "loop.csv", tmp_path / "model.json"
    data.to_csv(csv, index=False)
    mpmpp.save_model(mpmpp.Model("m", 10.0, ["OP"], ["PV"], {"PV": {"OP": mpmpp.TransferFunction([0.5], [1.0, -0.7], 2)}}),
                     model)
    assert main(["diagnose", str(model), str(csv)]) == 2
    err = capsys.readouterr().err
    assert "too short: 126 rows (0.35 h); need at least 150" in err
    assert "missing" not in err


def test_segment_and_block_options(tmp_path, capsys):
    data = pi_loop.simulate(pi_loop.FLOW, 1, rows=1441, setpoint_steps=True)
    csv, model = tmp_path / "loop.csv", tmp_path / "model.json"
    data.to_csv(csv, index=False)
    ident = model_from_data(data, ["OP"], ["PV"])
    ident.save(model)
    assert main(["diagnose", str(model), str(csv), "--segment", "20min", "--block", "15min", "--json"]) == 0
    capsys.readouterr()
    # --train-end must leave one segment of this record after it (20 min here, not a fixed 1 h)
    assert main(["diagnose", str(model), str(csv), "--segment", "20min", "--train-end", "3.6h"]) == 0
    capsys.readouterr()
    assert main(["diagnose", str(model), str(csv), "--segment", "20min", "--train-end", "3.8h"]) == 2
    assert "needs at least 0.333 h" in capsys.readouterr().err
    assert main(["diagnose", str(model), str(csv), "--segment", "0"]) == 2


# ---- guards: no lag 0, no sign flip without overwhelming evidence ----------------------------

def foptd_model(loop, scale=1.0, delay=None, name="hand-written"):
    a, b0, b1, d = pi_loop.foptd_coefficients(loop, 10.0)
    g = mpmpp.TransferFunction([scale * b0, scale * b1], [1.0, -a], d if delay is None else delay)
    return mpmpp.Model(name, 10.0, ["OP"], ["PV"], {"PV": {"OP": g}})


@pytest.mark.parametrize("delay, num", [(2, [0.3, 0.1]), (0, [0.0, 0.3]), (1, [0.0, 0.0, 0.3]), (1, [0.3])])
def test_delay_search_never_reaches_lag_zero(delay, num):
    from mpmpp.diagnose.pipeline import diagnosis_signals
    from mpmpp.diagnose.shapes import first_lag, process_shapes

    data = pi_loop.simulate(pi_loop.FLOW, 1)
    model = mpmpp.Model("m", 10.0, ["OP"], ["PV"], {"PV": {"OP": mpmpp.TransferFunction(num, [1.0, -0.7], delay)}})
    sig = diagnosis_signals(model, data).sig
    shapes = [s.shape for s in process_shapes(sig, 0) if s.effect == "delay"]
    lags = [first_lag(g) for g in shapes]
    nominal = first_lag(sig.rows[0][0])
    assert min(lags) == (1 if nominal > 1 else 2) and nominal not in lags
    assert min(g.delay for g in shapes) >= 0


@pytest.mark.parametrize("loop, action", [(pi_loop.FLOW, 1), (pi_loop.PRESSURE, -1)])
def test_single_loop_controller_action_from_the_data(loop, action):
    from mpmpp.diagnose.loops import single_loops
    from mpmpp.diagnose.pipeline import diagnosis_signals

    data = pi_loop.simulate(loop, 4, setpoint_steps=True)
    loops = single_loops(diagnosis_signals(foptd_model(loop), data).sig, data)
    assert [(lp.output, lp.input, lp.action) for lp in loops] == [(0, 0, action)]


def _fit(effect, theta, se, gain=1.0):
    from mpmpp.diagnose.process import Fit
    from mpmpp.diagnose.shapes import Shape

    g = mpmpp.TransferFunction([0.5 * gain], [1.0, -0.5], 1)
    return Fit(Shape(effect, "OP", "input", g, g, 1.0, 1), 0, 0.0, 0.0, theta, se, [], 1.0)


def test_sign_flip_needs_five_standard_errors_and_the_controller_action():
    from mpmpp.diagnose.process import flips_sign_without_evidence as flips

    assert not flips(_fit("gain", 1.5, 1.0))                 # same sign: no guard
    assert flips(_fit("delay", -14.0, 3.0))                  # 4.7 se: not overwhelming
    assert not flips(_fit("gain", -14.0, 2.0))               # 7 se, no loop action known
    assert flips(_fit("gain", -14.0, 2.0), action=1)         # new gain -14 < 0, controller needs > 0
    assert not flips(_fit("gain", -14.0, 2.0, gain=-1.0), action=1)   # new gain +14: agrees
    assert not flips(_fit("missing_coupling", -3.0, 1.0))    # a new channel has no sign to flip


def test_a_model_with_the_wrong_sign_is_corrected():
    """The hand-written model has the process gain's sign wrong: the data's evidence is
    overwhelming and the controller's action agrees, so the flip is reported."""
    loop = pi_loop.FLOW
    data = pi_loop.simulate(loop, 5, setpoint_steps=True)
    res = diagnose(foptd_model(loop, scale=-1.0), data)
    assert res.findings[0].effect == "gain"
    assert -1.3 < res.findings[0].estimate["gain_ratio"] < -0.7


# ---- valve stiction in a single loop ----------------------------------------------------------

def stiction_study_loop(seed, valve=None, oscillation=0.0):
    """A flow loop of the stiction study (first order 15 s, 1 sample dead time, PI), AR(1) plus
    white disturbance, optionally an external sinusoid of ``oscillation`` PV units."""
    from mpmpp.stiction.loop import Process, coloured_noise, simulate_pi_loop

    n = 751
    rng = np.random.default_rng(seed)
    p = np.exp(-10 / 15)
    d = coloured_noise(rng, n, 0.3, 0.8) + 0.05 * rng.standard_normal(n)
    d += oscillation * np.sin(2 * np.pi * np.arange(n) / rng.uniform(25, 60) + rng.uniform(0, 2 * np.pi))
    rec = simulate_pi_loop(Process(b=(1 - p,), a=(1.0, -p), delay=1), 0.7, 1.5, n, valve=valve, disturbance=d)
    return pd.DataFrame({"time": 10.0 * np.arange(n), "OP": rec["op"], "PV": rec["pv"] + 20.0,
                         "PV_sp": rec["sp"] + 20.0})


@pytest.mark.parametrize("seed", [11, 12])
def test_sticking_valve_is_named_with_its_size(seed):
    from mpmpp._core import ActuatorNonlinearity

    data = stiction_study_loop(seed, ActuatorNonlinearity(stiction_s=4.0, stiction_j=2.0))
    res = diagnose(model_from_data(data, ["OP"], ["PV"]).model, data)
    top = res.findings[0]
    assert top.effect == "input_nonlinearity" and top.onset_s == 0.0
    assert top.estimate["kind"] in ("stick_slip", "he", "backlash") and 2.0 < top.estimate["S"] < 8.0
    # A calibrated probability (fit on the stiction study's tuning loops): more likely right than not.
    assert top.confidence > 0.5
    assert top.error_after < 0.95 * top.error_before
    # the linear stand-ins (a noise change, a changed gain) are not reported beside it
    assert [f.effect for f in res.findings] == ["input_nonlinearity"]


# Seeds 12, 13, 17: on 11, 14 and 15 identify sets the oscillation apart and what is left
# identifies no channel (the record is refused; test_periodic_disturbance.py).
@pytest.mark.parametrize("seed", [12, 13, 17])
def test_external_oscillation_through_a_linear_valve_is_not_stiction(seed):
    data = stiction_study_loop(seed, oscillation=1.0)
    res = diagnose(model_from_data(data, ["OP"], ["PV"]).model, data)
    assert not any(f.effect == "input_nonlinearity" for f in res.findings)
    # the period drawn in stiction_study_loop, in seconds
    rng = np.random.default_rng(seed)
    rng.standard_normal(951), rng.standard_normal(751)
    period_s = 10.0 * rng.uniform(25, 60)
    note = next(n for n in res.notes if "oscillates with a period" in n)
    assert float(note.split("period of ")[1].split(" s")[0]) == pytest.approx(period_s, rel=0.03)


# ---- the valve in the model file --------------------------------------------------------------

def test_update_writes_the_valve_and_the_error_falls(tmp_path, capsys):
    """identify -> diagnose -> update on a sticking valve: the new model file carries the valve
    in its actuators block, compare simulates it before the channel, and the one-step error
    falls in update's held-out report and in compare on the whole record."""
    from mpmpp._core import ActuatorNonlinearity

    data = stiction_study_loop(11, ActuatorNonlinearity(stiction_s=4.0, stiction_j=2.0))
    csv, model, new = tmp_path / "loop.csv", tmp_path / "model.json", tmp_path / "new.json"
    data.to_csv(csv, index=False)
    assert main(["identify", str(csv), "--inputs", "OP", "--outputs", "PV", "-o", str(model)]) == 0
    assert main(["update", str(model), str(csv), "--apply", "F1", "-o", str(new), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    err = doc["errors"][0]
    assert err["error_after"] < 0.95 * err["error_before"]
    written = json.loads(new.read_text())
    assert written["actuators"]["version"] == 1
    valve = written["actuators"]["inputs"]["OP"]
    assert valve["kind"] in ("stick_slip", "he", "backlash") and 0.0 < valve["confidence"] <= 1.0
    assert "actuators" not in json.loads(model.read_text())

    def compared(path):
        assert main(["compare", str(path), str(csv), "--json"]) == 0
        return json.loads(capsys.readouterr().out)["outputs"][0]

    before, after = compared(model), compared(new)
    # the valve explains the limit cycle: the simulation fit rises from near 0 (seed 11: 1 % -> 26 %)
    assert after["fit_simulation"] > before["fit_simulation"] + 10.0
    assert after["fit_one_step"] > before["fit_one_step"]
    # the updated model, re-diagnosed, has no valve left to find
    res = diagnose(mpmpp.load_model(new), data)
    assert not any(f.effect == "input_nonlinearity" for f in res.findings)


def test_actuators_block_round_trip_and_old_files_unchanged(tmp_path):
    g = mpmpp.TransferFunction([0.3], [1.0, -0.7], 1)
    plain = mpmpp.Model("loop", 10.0, ["OP"], ["PV"], {"PV": {"OP": g}})
    path = tmp_path / "plain.json"
    mpmpp.save_model(plain, path)
    text = path.read_bytes()
    mpmpp.save_model(mpmpp.load_model(path), path)
    assert path.read_bytes() == text and b"actuators" not in text
    valve = {"kind": "stick_slip", "S": 3.9, "J": 1.0, "confidence": 0.99}
    with_valve = mpmpp.Model("loop", 10.0, ["OP"], ["PV"], {"PV": {"OP": g}}, {}, {"OP": valve})
    assert mpmpp.Model.from_json(with_valve.to_json()).actuator("OP") == valve
    assert plain.actuator("OP") is None


@pytest.mark.parametrize("block, message", [
    ({"version": 2, "inputs": {}}, "actuators.version: version 2 is not supported"),
    ({"inputs": {}}, 'actuators: missing field "version"'),
    ({"version": 1, "inputs": {"OP": {"kind": "sticky", "S": 1}}}, 'actuators.inputs.OP.kind: unknown kind "sticky"'),
    ({"version": 1, "inputs": {"OP": {"kind": "stick_slip", "S": 1}}}, 'missing field "J"'),
    ({"version": 1, "inputs": {"OP": {"kind": "stick_slip", "S": 1, "J": 2}}}, "actuators.inputs.OP.J: must be <= S"),
    ({"version": 1, "inputs": {"XX": {"kind": "backlash", "S": 1}}}, 'unknown input "XX"'),
    ({"version": 1, "inputs": {"OP": {"kind": "backlash", "S": 1, "confidence": 2}}}, "confidence: must be between 0 and 1"),
])
def test_bad_actuators_block_is_one_clear_error(tmp_path, block, message):
    doc = {"sample_time_s": 10.0, "inputs": ["OP"], "outputs": ["PV"],
           "process": {"PV": {"OP": {"num": [0.3], "den": [1.0, -0.7], "delay": 1}}}, "actuators": block}
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=message):
        mpmpp.load_model(path)
