"""The command line of compare / diagnose / update on a user's model + CSV pair."""
import json
import os

import mpmpp
from mpmpp.cli import main

from example_cases import GAIN_CHANGE, NOISE_CHANGE, data_path, hidden_effect, model_path


def test_compare_cli_writes_figures_and_json(tmp_path, capsys):
    assert main(["compare", str(model_path(NOISE_CHANGE)), str(data_path(NOISE_CHANGE)), "--json",
                 "--out", str(tmp_path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [o["output"] for o in doc["outputs"]] == mpmpp.load_model(model_path(NOISE_CHANGE)).outputs
    assert len(list(tmp_path.glob("*.png"))) == 6


def test_diagnose_then_update_cli(tmp_path, capsys):
    truth = hidden_effect(GAIN_CHANGE)
    model, data = str(model_path(GAIN_CHANGE)), str(data_path(GAIN_CHANGE))
    assert main(["diagnose", model, data, "--json", "--out", str(tmp_path)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["findings"][0]["effect"] == truth["effect"]
    assert (tmp_path / f"diagnose_{truth['output']}.png").exists()
    new = tmp_path / "new.json"
    assert main(["update", model, data, "--apply", "F1", "-o", str(new)]) == 0
    text = capsys.readouterr().out
    assert "error" in text and new.exists()
    g_old = mpmpp.load_model(model).process(truth["output"], truth["input"])
    g_new = mpmpp.load_model(new).process(truth["output"], truth["input"])
    assert abs(g_new.dc_gain() / g_old.dc_gain() - truth["ratio"]) < 0.2 * truth["ratio"]


def test_update_never_overwrites_silently(tmp_path, capsys):
    model = tmp_path / "model.json"
    model.write_bytes(model_path(GAIN_CHANGE).read_bytes())
    before = model.read_bytes()
    data = str(data_path(GAIN_CHANGE))
    # The input model itself, also under another spelling of its path: refused, untouched.
    for target in (model, tmp_path / "." / "model.json"):
        assert main(["update", str(model), data, "--apply", "F1", "-o", str(target)]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "is the input model" in err and "--force" in err
        assert model.read_bytes() == before
    # Any other existing file: refused too.
    other = tmp_path / "other.json"
    other.write_text("keep me")
    assert main(["update", str(model), data, "--apply", "F1", "-o", str(other)]) == 2
    assert "exists" in capsys.readouterr().err and other.read_text() == "keep me"
    # With --force the input model is replaced, and the output says so.
    os.chmod(model, 0o640)
    assert main(["update", str(model), data, "--apply", "F1", "-o", str(model), "--force"]) == 0
    assert f"replaced {model}" in capsys.readouterr().out
    assert model.read_bytes() != before and mpmpp.load_model(model).outputs == [hidden_effect(GAIN_CHANGE)["output"]]
    assert os.stat(model).st_mode & 0o777 == 0o640


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    model, data = str(model_path(GAIN_CHANGE)), str(data_path(GAIN_CHANGE))
    assert main(["diagnose", model, str(tmp_path / "missing.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "missing.csv" in err
    assert main(["update", model, data, "--apply", "F7", "-o", str(tmp_path / "x.json")]) == 2
    assert "F7" in capsys.readouterr().err


def test_a_model_the_data_cannot_check_is_named_in_one_line(tmp_path, capsys):
    """An unstable channel (its simulated output diverges: diagnose stopped with 'SVD did not
    converge'), a gain that overflows (diagnose: 'num has a non-finite coefficient' after
    RuntimeWarnings; now refused on reading the file, and for a Model built in Python by the
    analysis) and a dead time longer than the record (compare stopped with a NumPy broadcast
    error) are named by their field, exit 2."""
    data = str(data_path(GAIN_CHANGE))
    doc = json.loads(model_path(GAIN_CHANGE).read_text())
    (o, row), = doc["process"].items()
    (i, channel), = row.items()
    for field, value, message in (("den", [1.0, -1.5], f"process.{o}.{i}: unstable, a pole has |p| = 1.5 > 1"),
                                  ("num", [1e308], f"process.{o}.{i}.num[0]: too large to compute with"),
                                  ("delay", 100000, f"process.{o}.{i}.delay: 100000 samples")):
        path = tmp_path / f"{field}.json"
        path.write_text(json.dumps({**doc, "process": {o: {i: {**channel, field: value}}}}))
        for command in ("compare", "diagnose"):
            assert main([command, str(path), data]) == 2
            err = capsys.readouterr().err.strip()
            assert "\n" not in err and message in err


def test_an_empty_model_column_is_named_in_one_line(tmp_path, capsys):
    """A model input the export left empty used to read as 'no stretch of rows without missing
    values' (compare, diagnose) or as a training period without usable windows (detect)."""
    model = model_path(GAIN_CHANGE)
    name = json.loads(model.read_text())["inputs"][0]
    lines = data_path(GAIN_CHANGE).read_text().splitlines()
    k = lines[0].split(",").index(name)
    rows = [line.split(",") for line in lines[1:]]
    for r in rows:
        r[k] = ""
    path = tmp_path / "empty_input.csv"
    path.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    for command in ("compare", "diagnose", "detect"):
        assert main([command, str(model), str(path)]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and f"column '{name}' (model input) has no values: all {len(rows)} rows" in err


def test_scattered_missing_values_are_counted_in_the_refusal(tmp_path, capsys):
    """Every tenth output sample lost leaves no complete stretch: the refusal counts the missing
    values per column (it read as a record without any stretch, the cause left to guess), and
    detect says why its windows were skipped."""
    model = model_path(GAIN_CHANGE)
    name = json.loads(model.read_text())["outputs"][0]
    lines = data_path(GAIN_CHANGE).read_text().splitlines()
    k = lines[0].split(",").index(name)
    rows = [line.split(",") for line in lines[1:]]
    for r in rows[::10]:
        r[k] = ""
    path = tmp_path / "holes.csv"
    path.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    for command in ("compare", "diagnose", "stiction", "detect"):
        args = ([command, str(path), "--op", json.loads(model.read_text())["inputs"][0], "--pv", name]
                if command == "stiction" else [command, str(model), str(path)])
        assert main(args) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err
        assert (f"(missing values: {name} {len(rows[::10])})" in err if command != "detect"
                else "a window is skipped for a missing value or a time gap in it" in err), err


def test_update_json_carries_the_diagnosis_notes_and_out_gets_update_json(tmp_path, capsys):
    """A model file without a noise model: the diagnosis estimates one and says so; update's
    JSON (stdout and --out DIR/update.json, the same document) carries that note."""
    full = mpmpp.load_model(model_path(GAIN_CHANGE))
    bare = mpmpp.Model(full.name, full.sample_time_s, full.inputs, full.outputs,
                       process={o: {i: full.process(o, i) for i in full.inputs} for o in full.outputs})
    model = tmp_path / "no_noise_model.json"
    mpmpp.save_model(bare, str(model))
    out = tmp_path / "out"
    assert main(["update", str(model), str(data_path(GAIN_CHANGE)), "--apply", "F1", "-o",
                 str(tmp_path / "new.json"), "--json", "--out", str(out)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert any("noise model" in n for n in doc["notes"])
    assert json.loads((out / "update.json").read_text()) == doc
