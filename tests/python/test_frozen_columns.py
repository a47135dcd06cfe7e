"""A model column with one value throughout the record (a frozen historian tag, a stuck
signal). An input: every analysis names it, and none claims the channels from it were checked.
An output: nothing can be checked against it, and every command says so in one line."""
import json

import numpy as np
import pandas as pd
import pytest

import mpmpp
from mpmpp import cli
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose

import closed_loop_case as loop

FROZEN_NOTE = "u: one value throughout the record (a frozen tag or a stuck signal)"


def frozen_loop():
    data = loop.simulate(n=8000, seed=2, onset=4000, noise_den_after=[1.0, -0.9])
    data["u"] = 100.0
    data.loc[[10, 2000], "u"] = np.nan
    return data


def test_check_names_a_frozen_column(tmp_path, capsys):
    """A model column with one value wherever it is known (lost rows aside) is named with it."""
    model = mpmpp.Model("m", 1.0, ["OP"], ["PV"], {"PV": {"OP": mpmpp.TransferFunction([0.5], [1.0, -0.5], 1)}})
    mpmpp.save_model(model, tmp_path / "m.json")
    t = np.arange(300)
    op, pv = np.full(300, 42.5), np.cos(t / 5.0)
    op[7] = np.nan
    pd.DataFrame({"time": t, "OP": op, "PV": pv}).to_csv(tmp_path / "d.csv", index=False)
    assert cli.main(["check", str(tmp_path / "m.json"), str(tmp_path / "d.csv"), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)["data"]
    assert data["frozen"] == {"OP": 42.5} and data["held"] == {}
    assert cli.main(["check", str(tmp_path / "m.json"), str(tmp_path / "d.csv")]) == 0
    assert "no channel through it can be checked): OP = 42.5" in capsys.readouterr().out


def test_a_frozen_input_is_said_to_leave_the_process_model_unchecked():
    """A tag the historian stopped updating: one value for the whole record (a few lost rows
    too). Its channel cannot be tested, so the disturbance verdict must not say that the
    process model still fits, and a note names the column."""
    result = diagnose(loop.model(), frozen_loop())
    assert any(n.startswith(FROZEN_NOTE) for n in result.notes)
    assert not [f for f in result.findings if f.effect in PROCESS_EFFECTS]
    disturbance = [f for f in result.findings if f.effect in ("noise_change", "output_drift")]
    assert disturbance and all("the process model is not checked there (u holds one value)" in f.explanation
                               for f in disturbance)
    moving = diagnose(loop.model(), loop.simulate(n=8000, seed=2, onset=4000, noise_den_after=[1.0, -0.9]))
    assert not any("one value throughout" in n for n in moving.notes)
    assert all("not checked" not in f.explanation for f in moving.findings)
    assert any("the process model still fits" in f.explanation for f in moving.findings)


def test_compare_and_detect_name_a_frozen_input():
    data = frozen_loop()
    compared = mpmpp.compare(loop.model(), data)
    assert compared.frozen_inputs == ["u"] and compared.to_dict()["frozen_inputs"] == ["u"]
    assert f"note: {FROZEN_NOTE}" in compared.summary()
    detected = mpmpp.detect(loop.model(), data)
    assert any(n.startswith(FROZEN_NOTE) for n in detected.notes)
    moving = loop.simulate(n=8000, seed=2)
    assert mpmpp.compare(loop.model(), moving).frozen_inputs == []
    assert not any("one value throughout" in n for n in mpmpp.detect(loop.model(), moving).notes)


@pytest.mark.parametrize("command", ["compare", "detect", "diagnose", "update", "identify"])
def test_a_frozen_output_is_refused_in_one_line_naming_it(command, tmp_path, capsys):
    data = loop.simulate(n=8000, seed=2)
    data["y"] = 20.0
    data.loc[[10, 2000], "y"] = np.nan
    data.to_csv(tmp_path / "d.csv", index=False)
    mpmpp.save_model(loop.model(), tmp_path / "m.json")
    pair = [str(tmp_path / "m.json"), str(tmp_path / "d.csv")]
    args = {"update": ["update", *pair, "--apply", "F1", "-o", str(tmp_path / "new.json")],
            "identify": ["identify", str(tmp_path / "d.csv"), "--inputs", "u", "--outputs", "y",
                         "-o", str(tmp_path / "new.json")]}.get(command, [command, *pair])
    assert cli.main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "output 'y'" in err and "one value throughout" in err
    assert not (tmp_path / "new.json").exists()


def test_an_input_held_for_hours_is_named_with_its_stretch():
    """An input that stops moving for the last 4 h of 11 h (a stale tag): diagnose names the
    stretch, and a disturbance verdict after it does not say the process model still fits."""
    data = loop.simulate(n=8000, seed=2, onset=4000, noise_den_after=[1.0, -0.9])
    held_from = 8000 - int(4 * 3600 / loop.TS)
    data.loc[held_from:, "u"] = data["u"][held_from]
    result = diagnose(loop.model(), data)
    note = f"u: one value from t={held_from * loop.TS / 3600:.2f} h to t={7999 * loop.TS / 3600:.2f} h (4.0 h"
    assert any(n.startswith(note) for n in result.notes)
    # the noise change is dated 5.6 h: u holds one value on 72 % of the rows after it
    [verdict] = [f for f in result.findings if f.effect == "noise_change"]
    assert "the process model is not checked there (u holds one value)" in verdict.explanation


def test_held_stretches_match_a_plain_run_count():
    x = np.array([1.0, 1, 1, 2, 2, 2, 2, np.nan, 3, 3, 3, 3, 3, 4])
    assert mpmpp.held_values.held_stretches(x, 4) == [(3, 7), (8, 13)]
    assert mpmpp.held_values.held_stretches(x, 5) == [(8, 13)]
    assert mpmpp.held_values.held_rows(x, 4).tolist() == [False] * 3 + [True] * 4 + [False] + [True] * 5 + [False]


def test_check_lists_the_stretches_a_column_holds(tmp_path, capsys):
    data = loop.simulate(n=8000, seed=2)
    data.loc[1000:1800, "u"] = 100.0    # 801 rows = 1.1 h at 5 s
    data.loc[5000:5500, "u"] = 101.0    # 501 rows = 0.7 h: too short to name
    data.to_csv(tmp_path / "d.csv", index=False)
    mpmpp.save_model(loop.model(), tmp_path / "m.json")
    assert cli.main(["check", str(tmp_path / "m.json"), str(tmp_path / "d.csv"), "--json"]) == 0
    held = json.loads(capsys.readouterr().out)["data"]["held"]
    assert held == {"u": [{"start_s": 1000 * loop.TS, "end_s": 1800 * loop.TS}]}
