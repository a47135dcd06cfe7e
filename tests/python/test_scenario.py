"""Scenario files: JSON round trip, one-line errors naming the field, the CLI and plots."""
import json

import numpy as np
import pytest

import mpmpp
from mpmpp import scenarios
from mpmpp.cli import main
from mpmpp.scenario import load_scenario, parse_scenario


def short(spec, samples=300):
    spec["duration_s"] = samples * spec["sample_time_s"]
    spec["events"] = [e for e in spec["events"] if e["time_s"] < spec["duration_s"]]
    return spec


def test_json_round_trip_gives_the_same_data(tmp_path):
    spec = scenarios.paper_mimo()
    path = tmp_path / "mimo.json"
    path.write_text(json.dumps(spec))
    assert load_scenario(path).spec == spec
    spec = short(spec, 2000)
    path.write_text(json.dumps(spec))
    assert mpmpp.simulate(path, seed=5).equals(mpmpp.simulate(spec, seed=5))


def test_paper_numbers():
    siso = parse_scenario(scenarios.paper_siso())
    assert siso.num_samples == 10800 and [e.sample for e in siso.events] == [5040, 7920]
    g = siso.truth.process("dry_weight", "stock_flow")
    assert g.delay == 17 and list(g.num) == [0.1003] and list(g.den) == [1.0, -0.9048]
    assert list(siso.events[1].model.num) == [0.2006]  # gain doubled
    mimo = parse_scenario(scenarios.paper_mimo())
    assert mimo.num_samples == 20700 and [e.sample for e in mimo.events] == [6900, 12000, 15000]
    assert [(e.output, e.input) for e in mimo.events[1:]] == [(2, 0), (0, 0)]
    assert list(mimo.tuning.mv_max) == [250, 180, 180] and list(mimo.tuning.mv_max_move) == [0.2, 1, 1]
    assert [mimo.model.process(o, "stock_flow").delay for o in mimo.outputs] == [15, 19, 9]


def mutate(path, value):
    spec = scenarios.paper_siso()
    *keys, last = path
    target = spec
    for k in keys:
        target = target[k]
    if value is KeyError:
        del target[last]
    else:
        target[last] = value
    return spec


@pytest.mark.parametrize("path, value, message", [
    (["duration_s"], KeyError, "duration_s: is required"),
    (["duration_s"], -1, "duration_s: must be > 0"),
    (["trhuth"], {}, "trhuth: unknown key"),
    (["truth", "sigma", "dry_weight"], "0.05", "truth.sigma.dry_weight: must be a number"),
    (["truth", "sigma", "dry_weight"], 1e200, "truth.sigma.dry_weight: too large to compute with, got 1e+200"),
    (["truth", "sigma", "wet_weight"], 0.1, "truth.sigma.wet_weight: unknown key"),
    (["controller", "mv", "stock_flow", "max_move"], 0, "controller.mv.stock_flow.max_move: must be > 0"),
    (["controller", "mv", "stock_flow", "target"], 5000, "controller.mv.stock_flow.target: must lie within"),
    (["controller", "cv", "dry_weight", "target"], KeyError, "controller.cv.dry_weight.target: is required"),
    (["controller", "control_horizon"], 50, "controller.control_horizon: must be <= prediction_horizon"),
    (["events", 0, "time_s"], 2.5, "events[0].time_s: must be a multiple of sample_time_s"),
    (["events", 0, "time_s"], 1e9, "events[0].time_s: is after the end"),
    (["events", 0, "type"], "quake", "events[0].type: unknown event type 'quake'"),
    (["events", 1, "input"], "steam", "events[1].input: unknown input 'steam'"),
    (["events", 1, "factor"], KeyError, "events[1].factor: is required"),
    (["events", 1, "switch"], "swap", "events[1].switch: must be one of replay, fresh, not 'swap'"),
    (["events", 0, "model"], {"num": [1], "den": [0]}, "events[0].model: den[0] must be non-zero"),
    (["process", "dry_weight", "stock_flow", "delay"], -1, "process.dry_weight.stock_flow.delay"),
    (["truth", "actuators"], {"stock_flow": {"deadband": -1}}, "truth.actuators.stock_flow.deadband: must be >= 0"),
])
def test_errors_are_one_line_naming_the_field(path, value, message):
    with pytest.raises(ValueError) as err:
        parse_scenario(mutate(path, value))
    text = str(err.value)
    assert "\n" not in text and text.startswith(message.split(":")[0]) and message in text, text


def test_channel_missing_from_truth_cannot_change_gain():
    spec = scenarios.paper_mimo()
    spec["events"] = [{"time_s": 0, "type": "gain", "output": "press_dry_weight", "input": "steam_3", "factor": 2}]
    with pytest.raises(ValueError, match=r"events\[0\]: gain event on press_dry_weight <- steam_3"):
        parse_scenario(spec)


def test_time_constant_and_delay_events_keep_the_gain():
    spec = short(scenarios.paper_siso())
    spec["events"] = [
        {"time_s": 50, "type": "time_constant", "output": "dry_weight", "input": "stock_flow", "factor": 3.0},
        {"time_s": 100, "type": "delay", "output": "dry_weight", "input": "stock_flow", "delay": 25}]
    sc = parse_scenario(spec)
    slow, late = sc.events[0].model, sc.events[1].model
    a = 0.9048 ** (1 / 3)  # T = -Ts / ln(a): three times the time constant
    assert np.allclose(slow.den, [1, -a]) and abs(slow.dc_gain() - 0.1003 / (1 - 0.9048)) < 1e-12
    assert late.delay == 25 and np.allclose(late.den, slow.den)  # the delay change applies to the new truth


def test_cli_simulate_writes_data_plot_and_qps(tmp_path):
    spec = short(scenarios.paper_siso(), 400)
    (tmp_path / "s.json").write_text(json.dumps(spec))
    out, fig, qps = tmp_path / "d.csv", tmp_path / "f.png", tmp_path / "q.npz"
    assert main(["simulate", str(tmp_path / "s.json"), "-o", str(out), "--seed", "4", "--plot", str(fig),
                 "--record-qps", str(qps)]) == 0
    df = mpmpp.load_data(out)
    expected = mpmpp.simulate(spec, seed=4)
    assert np.allclose(df.to_numpy(), expected.to_numpy(), rtol=0, atol=0)
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rec = np.load(qps)
    assert rec["q"].shape == (400, rec["P"].shape[0]) and rec["l"].shape == (400, rec["A"].shape[0])


def test_cli_bad_scenario_is_exit_2_with_one_line(tmp_path, capsys):
    spec = scenarios.paper_siso()
    spec["truth"]["sigma"]["dry_weight"] = -1
    (tmp_path / "s.json").write_text(json.dumps(spec))
    assert main(["simulate", str(tmp_path / "s.json"), "-o", str(tmp_path / "d.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "s.json: truth.sigma.dry_weight: must be >= 0" in err


def test_paper_mimo_plots_outputs_and_inputs(tmp_path):
    assert main(["simulate", "--paper", "mimo", "--seed", "1", "--plot", str(tmp_path / "m.png")]) == 0
    assert (tmp_path / "m_outputs.png").exists() and (tmp_path / "m_inputs.png").exists()
