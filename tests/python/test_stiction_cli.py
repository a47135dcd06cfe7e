"""``mpmpp stiction`` on a 751-row, 10 s PI-loop record, and its one-line errors."""
import json

import numpy as np
import pandas as pd
import pytest
from mpmpp._core import ActuatorNonlinearity
from mpmpp.cli import main
from mpmpp.stiction.loop import Process, coloured_noise, simulate_pi_loop


def write_loop(path, n=751, valve=None, seed=3, oscillation_period=None):
    p = np.exp(-10 / 15)
    rng = np.random.default_rng(seed)
    d = coloured_noise(rng, n, 0.3, 0.8)
    if oscillation_period is not None:
        d = d + np.sin(2 * np.pi * np.arange(n) / oscillation_period)
    rec = simulate_pi_loop(Process(b=(1 - p,), a=(1.0, -p)), 0.7, 1.5, n, valve=valve, disturbance=d)
    pd.DataFrame({"time": 10.0 * np.arange(n), "FIC101.OP": rec["op"], "FIC101.PV": rec["pv"],
                  "FIC101.SP": rec["sp"]}).to_csv(path, index=False)


def test_stiction_command_on_a_sticky_loop(tmp_path, capsys):
    data = tmp_path / "loop.csv"
    write_loop(data, valve=ActuatorNonlinearity(stiction_s=4.0, stiction_j=2.0))
    code = main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV", "--sp", "FIC101.SP"])
    out = capsys.readouterr().out
    assert code == 0
    assert "751 samples" in out and "mpmpp: STICTION" in out and "S=" in out
    for name in ("horch", "bicoherence", "kano", "curve_fit"):
        assert name in out
    main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV", "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert doc["mpmpp"]["stiction"] is True and 2.0 < doc["mpmpp"]["size"]["S"] < 8.0
    assert doc["mpmpp"]["oscillating_disturbance_period_samples"] is None


def test_stiction_command_names_an_external_oscillation(tmp_path, capsys):
    data = tmp_path / "loop.csv"
    write_loop(data, oscillation_period=37.0)
    assert main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV"]) == 0
    out = capsys.readouterr().out
    assert "no actuator nonlinearity" in out or "no stiction" in out
    assert "period of 37" in out and "linear valve with an oscillating disturbance" in out


@pytest.mark.parametrize("args, n, message", [
    (["--op", "OP", "--pv", "FIC101.PV"], 751, "no column 'OP'"),
    (["--op", "FIC101.OP", "--pv", "FIC101.PV"], 60, "too short: 60 rows"),
])
def test_stiction_command_errors(tmp_path, capsys, args, n, message):
    data = tmp_path / "loop.csv"
    write_loop(data, n=n)
    assert main(["stiction", str(data), *args]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and str(data) in err and len(err.splitlines()) == 1


def test_a_historian_gap_or_missing_values_split_the_fit_and_say_so(tmp_path, capsys):
    """Rows left out (a step of 3 samples: two missing rows on the grid) and a missing PV: the
    valve fit runs over the three stretches of consecutive complete rows; the baselines, which
    need one unbroken series, on the longest, as on that stretch alone."""
    data, alone = tmp_path / "loop.csv", tmp_path / "alone.csv"
    write_loop(data, n=900, valve=ActuatorNonlinearity(stiction_s=4.0, stiction_j=2.0))
    df = pd.read_csv(data).drop(index=[100, 101])
    df.loc[df.index[50], "FIC101.PV"] = np.nan
    df.to_csv(data, index=False)
    df.iloc[100:].to_csv(alone, index=False)
    main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV", "--json"])
    doc = json.loads(capsys.readouterr().out)
    main(["stiction", str(alone), "--op", "FIC101.OP", "--pv", "FIC101.PV", "--json"])
    ref = json.loads(capsys.readouterr().out)
    assert doc["samples"] == 897 and ref["samples"] == 798
    assert doc["notes"][0] == ("3 rows skipped (missing values, time gaps, stretches under 30 rows); the valve fit "
                               "uses 3 stretch(es), 897 rows; the baselines the longest, rows 102-899")
    assert doc["baselines"] == ref["baselines"] and ref["notes"] == doc["notes"][1:]
    assert doc["mpmpp"]["stiction"] is ref["mpmpp"]["stiction"] is True


def test_stretches_too_short_for_the_literature_tests_leave_them_out_and_say_why(tmp_path, capsys):
    """PV lost every 37th row of a 2 h record: the valve fit runs on the 36-row stretches, the
    baselines, which need one unbroken series of 128 samples, are not run (their verdict null
    with the reason) instead of failing the command (a NumPy broadcasting error before)."""
    data = tmp_path / "loop.csv"
    write_loop(data)
    df = pd.read_csv(data)
    df.loc[df.index[::37], "FIC101.PV"] = np.nan
    df.to_csv(data, index=False)
    assert main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV", "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["samples"] == 720
    for name in ("horch", "bicoherence", "kano", "curve_fit"):
        assert doc["baselines"][name] == {
            "stiction": None, "not_run": "the longest unbroken stretch holds 36 samples; the literature tests need 128"}
    assert main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV"]) == 0
    assert "  kano         not run: the longest unbroken stretch holds 36 samples" in capsys.readouterr().out


def test_timestamps_off_the_sample_grid_are_an_error_naming_the_row(tmp_path, capsys):
    """From row 400 on the file is sampled every 13 s for 100 rows: they drift off the 10 s grid,
    beyond what snapping a historian's jitter (a quarter of a sample) may move them."""
    data = tmp_path / "loop.csv"
    write_loop(data)
    df = pd.read_csv(data).iloc[:500]
    df.loc[400:, "time"] = df.loc[400, "time"] + 13.0 * np.arange(len(df) - 400)
    df.to_csv(data, index=False)
    assert main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV"]) == 2
    err = capsys.readouterr().err.strip()
    assert "column time:" in err and "s sample grid, more than the jitter tolerance" in err
    assert str(data) in err and len(err.splitlines()) == 1


def test_a_saturated_valve_is_no_stiction_and_says_why(tmp_path, capsys):
    """A valve that stops at an upper limit the OP passes in a fifth of the record: the best
    fit is the static limit, and the line names it instead of a bare 'stiction confidence'."""
    data = tmp_path / "loop.csv"
    write_loop(data)
    limit = float(np.quantile(pd.read_csv(data)["FIC101.OP"], 0.8))
    write_loop(data, valve=ActuatorNonlinearity(max=limit))
    assert main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV"]) == 0
    out = capsys.readouterr().out
    assert "mpmpp: no stiction: a static saturation_high" in out and "explains the data better" in out


def test_missing_values_split_the_record_and_every_stretch_is_fitted(tmp_path, capsys):
    """A historian's bad values in a 751-row record: the valve fit runs over every stretch
    between them (the valve at rest at each stretch's start), not the longest alone, and finds
    the sticking valve with the same size as on the complete record."""
    data = tmp_path / "loop.csv"
    write_loop(data, valve=ActuatorNonlinearity(stiction_s=4.0, stiction_j=2.0))
    main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV", "--json"])
    complete = json.loads(capsys.readouterr().out)
    df = pd.read_csv(data).astype({"FIC101.PV": object})
    df.loc[[250, 251, 500], "FIC101.PV"] = "Bad Input"
    df.to_csv(data, index=False)
    main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV", "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert doc["samples"] == 748 and doc["mpmpp"]["stiction"] is True
    assert doc["mpmpp"]["size"]["S"] == pytest.approx(complete["mpmpp"]["size"]["S"], rel=0.35)
    assert any("3 stretch(es), 748 rows" in note for note in doc["notes"])
