"""The command line frame: --version, --help everywhere, check's output."""
import json

import pytest

import mpmpp
from mpmpp import cli
from shared_cases import CASES


def test_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"mpmpp {mpmpp.__version__}"


@pytest.mark.parametrize("command", [[]] + [[name] for name in cli.COMMANDS])
def test_help_everywhere(command, capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(command + ["--help"])
    assert exit_.value.code == 0
    assert "usage: mpmpp" in capsys.readouterr().out


def test_check_json_summary(capsys):
    model, data = CASES / "P1" / "model.json", CASES / "P1" / "data.csv"
    assert cli.main(["check", str(model), str(data), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    m, df = mpmpp.load_model(model), mpmpp.load_data(data, mpmpp.load_model(model))
    [channel] = report["model"]["channels"]
    assert (channel["output"], channel["input"]) == m.channels()[0]
    assert channel["dc_gain"] == m.process(*m.channels()[0]).dc_gain()
    assert report["data"]["samples"] == len(df)
    assert report["data"]["duration_s"] == len(df) * m.sample_time_s
    assert report["data"]["missing"] == {c: 0 for c in df.columns if c != "time"}


def test_check_counts_missing_and_integrating_channel(tmp_path, capsys):
    integrator = mpmpp.TransferFunction([0.1], [1.0, -1.0])
    model = mpmpp.Model("int", 1.0, ["u"], ["y"], {"y": {"u": integrator}})
    mpmpp.save_model(model, tmp_path / "m.json")
    (tmp_path / "d.csv").write_text("time,u,y,y_sp,x\n0,1,,0,1\n1,,2,0,\n2,1,2,0,3\n")
    assert cli.main(["check", str(tmp_path / "m.json"), str(tmp_path / "d.csv")]) == 0
    out = capsys.readouterr().out
    assert "dc gain infinite" in out
    assert "missing values: u 1, y 1, x 1 (2 rows affected" in out
    assert "setpoints: y_sp" in out and "candidates for diagnose): x" in out
