"""`mpmpp monitor DETECTOR DATA`: the CLI plant path gives `detect`'s alarms, resumes from a
checkpoint exactly, speaks the data's own time, and refuses bad input in one line."""
import json
import os

import numpy as np
import pandas as pd
import pytest

import mpmpp
from cli_run import run_cli

HERE = os.path.dirname(os.path.abspath(__file__))
STREAM = os.path.join(HERE, "..", "data", "stream")
MODEL, DATA = os.path.join(STREAM, "model.json"), os.path.join(STREAM, "data.csv")


def alarm_keys(alarms):
    return [(a["kind"], a["output"], a.get("input"), round(a["start_s"], 6)) for a in alarms]


@pytest.fixture(scope="module")
def detected(tmp_path_factory):
    """`mpmpp detect --save-detector` run live on the data: its alarms and the detector file."""
    folder = tmp_path_factory.mktemp("detect")
    detector = folder / "detector.json"
    code, out, err = run_cli("detect", MODEL, DATA, "--train-end", 10800, "--config", "paper_siso", "--json",
                             "--save-detector", detector)
    assert code == 0, err
    alarms = json.loads(out)["alarms"]
    assert len(alarms) >= 2, "the data must alarm for the comparison to mean something"
    return detector, alarms


def _write_rows(df, rows, path):
    df.iloc[rows].to_csv(path, index=False, float_format="%.17g", na_rep="")
    return path


def test_monitor_gives_the_alarms_of_detect(detected):
    detector, alarms = detected
    code, out, err = run_cli("monitor", detector, DATA, "--json")
    assert code == 0, err
    got = json.loads(out)
    assert alarm_keys(got["alarms"]) == alarm_keys(alarms)
    assert got["passed_over"] == 0 and got["new_samples"] == len(pd.read_csv(DATA))
    assert got["skipped_windows"] and all("reason" in w for w in got["skipped_windows"])
    code, text, _ = run_cli("monitor", detector, DATA)
    assert code == 0 and "model-plant mismatch" in text and "alarm active now:" in text


def test_resuming_from_a_checkpoint_gives_the_alarms_of_one_run(detected, tmp_path):
    detector, alarms = detected
    df = pd.read_csv(DATA)
    cut = 4501  # inside a window, and after the first alarm
    assert alarms[0]["start_s"] < df["time"][cut] < alarms[-1]["start_s"]
    first = _write_rows(df, slice(0, cut), tmp_path / "first.csv")
    ckpt = tmp_path / "stream.ckpt"
    code, out, err = run_cli("monitor", detector, first, "--checkpoint", ckpt, "--json")
    assert code == 0, err
    part1 = json.loads(out)
    assert ckpt.exists() and json.loads(ckpt.read_text())["samples"] == cut
    # The historian export grew: the whole file again; rows already taken are passed over.
    code, out, err = run_cli("monitor", detector, DATA, "--checkpoint", ckpt, "--json")
    assert code == 0, err
    part2 = json.loads(out)
    assert part2["passed_over"] == cut and part2["new_samples"] == len(df) - cut
    assert alarm_keys(part1["alarms"] + part2["alarms"]) == alarm_keys(alarms)
    # Nothing new: nothing happens, the state does not move.
    before = ckpt.read_text()
    code, out, _ = run_cli("monitor", detector, DATA, "--checkpoint", ckpt, "--json")
    assert code == 0 and json.loads(out)["new_samples"] == 0 and json.loads(out)["alarms"] == []
    assert ckpt.read_text() == before


def test_a_file_of_only_the_new_rows_continues_the_stream(detected, tmp_path):
    detector, alarms = detected
    df = pd.read_csv(DATA)
    cut = 4000
    ckpt = tmp_path / "stream.ckpt"

    def run_rows(rows, name):
        return run_cli("monitor", detector, _write_rows(df, rows, tmp_path / name), "--checkpoint", ckpt, "--json")

    code, out, err = run_rows(slice(0, cut), "first.csv")
    assert code == 0, err
    parts = json.loads(out)["alarms"]
    # Rows that skip ahead of the stream (a gap) are refused, naming the file; state kept.
    state = ckpt.read_text()
    code, _, err = run_rows(slice(cut + 10, cut + 500), "gap.csv")
    assert code == 2 and "gap.csv" in err and len(err.strip().splitlines()) == 1, err
    assert ckpt.read_text() == state
    code, out, err = run_rows(slice(cut, None), "rest.csv")
    assert code == 0, err
    assert json.loads(out)["passed_over"] == 0
    assert alarm_keys(parts + json.loads(out)["alarms"]) == alarm_keys(alarms)


def test_alarms_are_reported_in_the_data_s_own_timestamps(detected, tmp_path):
    detector, alarms = detected
    df = pd.read_csv(DATA)
    origin = pd.Timestamp("2024-03-01T06:00:00Z")
    stamped = df.copy()
    stamped["time"] = [(origin + pd.Timedelta(seconds=float(s))).strftime("%Y-%m-%dT%H:%M:%SZ") for s in df["time"]]
    path = tmp_path / "stamped.csv"
    stamped.to_csv(path, index=False, float_format="%.17g", na_rep="")
    code, out, err = run_cli("monitor", detector, path, "--json")
    assert code == 0, err
    got = json.loads(out)["alarms"]
    assert alarm_keys(got) == alarm_keys(alarms)
    # Stamped as every command stamps times: ISO-8601 in the file's own offset beside start_s.
    expected = [(origin + pd.Timedelta(seconds=a["start_s"])).strftime("%Y-%m-%dT%H:%M:%SZ") for a in alarms]
    assert [a["start"] for a in got] == expected
    assert json.loads(out)["time"]["kind"] == "calendar"


def test_bad_input_is_one_line_and_exit_2(detected, tmp_path):
    detector, _ = detected
    other = tmp_path / "other.json"
    text = json.loads(open(detector, encoding="utf-8").read())
    text["train_end_s"] = 7200.0  # another detector: its checkpoints are not this one's
    other.write_text(json.dumps(text))
    ckpt = tmp_path / "c.ckpt"
    assert run_cli("monitor", other, _write_rows(pd.read_csv(DATA), slice(0, 100), tmp_path / "a.csv"),
                   "--checkpoint", ckpt)[0] == 0
    cases = [
        (["monitor", detector, DATA, "--checkpoint", ckpt], "c.ckpt"),
        (["monitor", detector, tmp_path / "missing.csv"], "missing.csv"),
        (["monitor", tmp_path / "nodetector.json", DATA], "nodetector.json"),
        (["monitor", detector, DATA, "--workers", 2], "--workers"),
        (["monitor", detector, DATA, MODEL], "3 arguments"),
    ]
    for argv, named in cases:
        code, _, err = run_cli(*argv)
        assert code == 2, argv
        assert named in err and len(err.strip().splitlines()) == 1, err


def test_monitor_in_python_equals_the_batch_detector(detected):
    """The library call behind the command against Detector.monitor on the same data."""
    from mpmpp.monitor import monitor

    detector, _ = detected
    batch = mpmpp.Detector.load(detector)
    data = mpmpp.load_data(DATA, batch.model)
    expected = batch.monitor(data)
    got = monitor(str(detector), data)
    assert alarm_keys(got.alarms) == alarm_keys(expected.alarms)
    last = expected.windows.index[-1]
    np.testing.assert_array_equal(got.last_window["indicator"], expected.indicator[last])
    assert got.active == [bool(v >= expected.threshold) for v in expected.indicator[last]]
