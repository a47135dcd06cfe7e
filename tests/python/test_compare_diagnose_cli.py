"""The command line of compare / diagnose / update on a user's model + CSV pair."""
import json

import mpmpp
from mpmpp.cli import main

from case_files import CASES


def test_compare_cli_writes_figures_and_json(tmp_path, capsys):
    folder = CASES / "P3"
    assert main(["compare", str(folder / "model.json"), str(folder / "data.csv"), "--json",
                 "--out", str(tmp_path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [o["output"] for o in doc["outputs"]] == ["basis_weight", "moisture"]
    assert len(list(tmp_path.glob("*.png"))) == 6


def test_diagnose_then_update_cli(tmp_path, capsys):
    folder = CASES / "P1"
    model, data = str(folder / "model.json"), str(folder / "data.csv")
    assert main(["diagnose", model, data, "--json", "--out", str(tmp_path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["findings"][0]["effect"] == "gain"
    assert (tmp_path / "diagnose_dry_weight.png").exists()
    new = tmp_path / "new.json"
    assert main(["update", model, data, "--apply", "F1", "-o", str(new)]) == 0
    text = capsys.readouterr().out
    assert "error" in text and new.exists()
    g_old = mpmpp.load_model(model).process("dry_weight", "stock_flow")
    g_new = mpmpp.load_model(new).process("dry_weight", "stock_flow")
    assert 1.6 < g_new.dc_gain() / g_old.dc_gain() < 2.4


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    folder = CASES / "P1"
    assert main(["diagnose", str(folder / "model.json"), str(tmp_path / "missing.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "missing.csv" in err
    assert main(["update", str(folder / "model.json"), str(folder / "data.csv"), "--apply", "F7",
                 "-o", str(tmp_path / "x.json")]) == 2
    assert "F7" in capsys.readouterr().err
