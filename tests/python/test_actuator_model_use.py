"""The model file's actuators block outside compare / diagnose / update: ``simulate`` runs the
valve a scenario's model describes, ``detect`` and ``identify.arx_oe_model`` see an input with
a valve as its simulated position. Each is checked against the same computation done by hand
(the valve position put in the data, a model without the block)."""
import numpy as np
import pandas as pd
import pytest

import mpmpp
from mpmpp.detect import Detector, detect
from mpmpp.identify import arx_oe_model
from mpmpp.scenario import parse_scenario
from mpmpp.stiction.valve import valve_position

CONFIG = {"preset": "siso", "window_s": 800.0, "step_s": 100.0, "arx_order_a": 4, "arx_order_b": 4,
          "resampled_models": 60}
VALVE = {"kind": "stick_slip", "S": 3.0, "J": 1.0}


def pi_scenario(**top):
    plant = {"num": [0.2], "den": [1.0, -0.9], "delay": 3}
    return {"sample_time_s": 1.0, "inputs": ["u"], "outputs": ["y"], "process": {"y": {"u": plant}},
            "noise": {"y": {"num": [1.0], "den": [1.0, -0.8]}},
            "truth": {"sigma": {"y": 0.2}},
            "controller": {"kind": "pid", "cv": {"y": {"target": 10.0}}, "mv": {"u": {"target": 50.0}},
                           "loops": [{"cv": "y", "mv": "u", "gain": 0.8, "integral_time_s": 8.0}]},
            "duration_s": 1500.0, "seed": 4, **top}


def test_simulate_runs_the_valve_of_the_scenarios_model():
    with_block = mpmpp.simulate(pi_scenario(actuators={"version": 1, "inputs": {"u": VALVE}}))
    spec = pi_scenario()
    spec["truth"]["actuators"] = {"u": {"stiction_s": 3.0, "stiction_j": 1.0}}
    by_truth = mpmpp.simulate(spec)
    pd.testing.assert_frame_equal(with_block, by_truth)
    assert not np.allclose(with_block["y"], mpmpp.simulate(pi_scenario())["y"])


def test_truth_actuators_win_over_the_models_block():
    spec = pi_scenario(actuators={"version": 1, "inputs": {"u": VALVE}})
    spec["truth"]["actuators"] = {"u": {}}
    pd.testing.assert_frame_equal(mpmpp.simulate(spec), mpmpp.simulate(pi_scenario()))


def test_scenario_model_keeps_its_block_and_old_scenarios_have_none():
    sc = parse_scenario(pi_scenario(actuators={"version": 1, "inputs": {"u": VALVE}}))
    assert sc.model.actuators_dict() == {"u": VALVE}
    assert parse_scenario(pi_scenario()).model.actuators_dict() == {}
    with pytest.raises(ValueError, match="actuators"):
        parse_scenario(pi_scenario(actuators={"version": 1, "inputs": {"u": {"kind": "sticky"}}}))


def record():
    """A PI loop with a sticking valve, and the model with and without the valve block."""
    steps = [{"time_s": 150.0 * k, "type": "setpoint", "output": "y", "value": 10.0 + 3.0 * (k % 2)}
             for k in range(1, 40)]
    df = mpmpp.simulate(pi_scenario(actuators={"version": 1, "inputs": {"u": VALVE}}, duration_s=6000.0,
                                    events=steps))
    with_valve = parse_scenario(pi_scenario(actuators={"version": 1, "inputs": {"u": VALVE}})).model
    linear = parse_scenario(pi_scenario()).model
    by_hand = df.copy()
    by_hand["u"] = valve_position(VALVE, df["u"].to_numpy())
    return df, with_valve, linear, by_hand


def test_detect_sees_the_valve_position():
    df, with_valve, linear, by_hand = record()
    got = detect(with_valve, df, 3000.0, CONFIG)
    ref = detect(linear, by_hand, 3000.0, CONFIG)
    np.testing.assert_allclose(got.scores, ref.scores, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(got.indicator, ref.indicator, rtol=1e-9, atol=1e-12)
    assert not np.allclose(got.scores, detect(linear, df, 3000.0, CONFIG).scores)


def test_saved_detector_keeps_the_valve(tmp_path):
    df, with_valve, _, _ = record()
    detector = Detector.train(with_valve, df, 3000.0, CONFIG)
    detector.save(tmp_path / "det.json")
    loaded = Detector.load(tmp_path / "det.json")
    np.testing.assert_allclose(loaded.monitor(df).scores, detector.monitor(df).scores, rtol=1e-12)


def test_arx_oe_model_estimates_the_linear_part_behind_the_valve():
    df, with_valve, linear, by_hand = record()
    got = arx_oe_model(with_valve, df, "y", na=4)
    ref = arx_oe_model(linear, by_hand, "y", na=4)
    np.testing.assert_allclose(got.oe.theta, ref.oe.theta, rtol=1e-9, atol=1e-12)
    assert not np.allclose(got.oe.theta, arx_oe_model(linear, df, "y", na=4).oe.theta)


def test_a_gap_restarts_the_valve_at_rest():
    from mpmpp.signals import through_actuators
    _, with_valve, _, _ = record()
    op = 50 + np.cumsum(np.random.default_rng(2).normal(0, 1, 300))
    op[120:125] = np.nan
    got = through_actuators(with_valve, op[:, None])[:, 0]
    assert np.isnan(got[120:125]).all()
    np.testing.assert_allclose(got[:120], valve_position(VALVE, op[:120]))
    np.testing.assert_allclose(got[125:], valve_position(VALVE, op[125:]))
