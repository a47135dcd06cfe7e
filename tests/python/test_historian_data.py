"""Historian exports as they come: calendar time (zones, daylight saving, epoch seconds),
jitter, gaps, repeats, status and text columns, faster sampling. Each repair is checked
against the clean grid the test started from (the expected result by construction)."""
import json
from datetime import datetime, timedelta, timezone

import numpy as np
import pandas as pd
import pytest

import mpmpp
from mpmpp.clock import Clock, parse_duration
from mpmpp.commands._pair import repair_lines

TS = 5.0


def model():
    return mpmpp.Model("m", TS, ["u"], ["y"], {"y": {"u": mpmpp.TransferFunction([0.5], [1.0, -0.5], 1)}})


def clean(n=200, seed=1):
    rng = np.random.default_rng(seed)
    return pd.DataFrame({"time": TS * np.arange(n), "u": rng.standard_normal(n).round(6),
                         "y": rng.standard_normal(n).round(6)})


def write(path, df, times=None):
    out = df.copy()
    if times is not None:
        out["time"] = times
    out.to_csv(path, index=False, na_rep="")
    return path


def iso(seconds, start=datetime(2026, 3, 29, 0, 30, tzinfo=timezone.utc), zone="Europe"):
    """ISO-8601 local times of Central Europe across the start of daylight saving time
    (2026-03-29 01:00 UTC: +01:00 becomes +02:00), written with their offsets."""
    out = []
    for s in seconds:
        t = start + timedelta(seconds=float(s))
        offset = 2 if t >= datetime(2026, 3, 29, 1, tzinfo=timezone.utc) else 1
        out.append((t + timedelta(hours=offset)).replace(tzinfo=None).isoformat(timespec="milliseconds")
                   + f"+0{offset}:00")
    return out


def test_durations():
    assert [parse_duration(x) for x in ["6h", "90min", "3600", "1.5d", "250ms", "5s", "2 h"]] == \
        [21600, 5400, 3600, 129600, 0.25, 5, 7200]
    for bad in ["6 hours", "abc", "-5", "", "1e"]:
        with pytest.raises(ValueError, match="not a duration"):
            parse_duration(bad, "--max-gap")


def test_daylight_saving_change_with_offsets_is_one_regular_record(tmp_path):
    df = clean(1000)
    back = mpmpp.load_data(write(tmp_path / "d.csv", df, iso(df["time"])), model())
    np.testing.assert_array_equal(back["time"], df["time"])
    np.testing.assert_array_equal(back[["u", "y"]], df[["u", "y"]])
    clock = Clock.of(back, TS)
    assert clock.stamp(0.0) == "2026-03-29T01:30:00+01:00"
    # One hour later the wall clock shows 03:30 (+02:00), as the file writes it.
    assert clock.stamp(3600.0) == "2026-03-29T03:30:00+02:00"
    assert clock.when("2026-03-29T02:30:00+01:00") == clock.when("2026-03-29T01:30:00Z") == 3600.0
    assert clock.when("2026-03-29T03:30:00") == 3600.0   # wall-clock time: the offset in use then
    assert clock.when("2026-03-29T01:45:00") == 900.0
    assert back.attrs["utc_offsets"] == [(0.0, 3600), (1800.0, 7200)]


def test_epoch_seconds_are_calendar_time(tmp_path):
    df = clean()
    start = datetime(2026, 3, 29, 0, 30, tzinfo=timezone.utc).timestamp()
    back = mpmpp.load_data(write(tmp_path / "d.csv", df, start + df["time"]), model())
    np.testing.assert_array_equal(back["time"], df["time"])
    assert back.attrs["time_origin"] == "2026-03-29T00:30:00Z"
    clock = Clock.of(back, TS)
    assert clock.stamp(600.0) == "2026-03-29T00:40:00Z"
    assert clock.when("2026-03-29T00:40:00Z") == clock.when("10min") == clock.when("600") == 600.0


def test_jitter_is_snapped_to_the_grid_and_counted(tmp_path):
    df = clean()
    rng = np.random.default_rng(2)
    jitter = rng.uniform(-0.2, 0.2, len(df)) * TS        # within the 25 % tolerance
    back = mpmpp.load_data(write(tmp_path / "d.csv", df, iso(df["time"] + jitter)), model())
    np.testing.assert_array_equal(back["time"], df["time"])
    np.testing.assert_array_equal(back[["u", "y"]], df[["u", "y"]])
    # The grid phase is the (upper) median offset: that row itself needs no move.
    moves = np.abs(jitter - np.sort(jitter)[len(jitter) // 2])
    r = back.attrs["repairs"]
    assert r["jitter_snapped"] == np.count_nonzero(moves > 1e-6 * TS) == len(df) - 1
    assert r["max_jitter_s"] == pytest.approx(moves.max(), abs=1e-3)


def test_gaps_become_missing_rows_or_split_the_record(tmp_path):
    df = clean()
    short, long = list(range(50, 53)), list(range(120, 160))   # 3 samples (20 s step), 40 samples
    kept = df.drop(index=short + long)
    back = mpmpp.load_data(write(tmp_path / "d.csv", kept, iso(kept["time"])), model(), max_gap_s=60)
    r = back.attrs["repairs"]
    assert [(g["missing_rows"], g["split"]) for g in r["gaps"]] == [(3, False), (1, True)]
    # Before the split: the clean grid with the short gap missing; then one missing row; then the rest.
    before = back.iloc[:120]
    np.testing.assert_array_equal(before["time"], df["time"][:120])
    assert before["u"].isna().to_numpy().nonzero()[0].tolist() == short
    assert back["u"].iloc[120:121].isna().all()
    np.testing.assert_array_equal(back["time"].iloc[121:], df["time"][160:])
    np.testing.assert_array_equal(back[["u", "y"]].iloc[121:], df[["u", "y"]].iloc[160:])
    assert back.attrs["segment_starts"] == [121]
    # A max gap above the outage bridges it with missing rows instead.
    bridged = mpmpp.load_data(tmp_path / "d.csv", model(), max_gap_s=parse_duration("1h"))
    np.testing.assert_array_equal(bridged["time"], df["time"])
    assert bridged["u"].isna().sum() == len(short) + len(long)


def test_repeats_out_of_order_and_local_daylight_saving(tmp_path):
    df = clean(20)
    doubled = pd.concat([df.iloc[:10], df.iloc[9:]])       # an export chunk boundary
    back = mpmpp.load_data(write(tmp_path / "d.csv", doubled), model())
    assert back.attrs["repairs"]["duplicates_dropped"] == 1
    np.testing.assert_array_equal(back.to_numpy(), df.to_numpy())
    swapped = df.iloc[[0, 1, 3, 2, 4]]
    with pytest.raises(ValueError, match=r"row 5, column time: 10 s is before row 4's 15 s"):
        mpmpp.load_data(write(tmp_path / "d.csv", swapped), model())
    # Local time without offsets repeats 02:00-03:00 when daylight saving ends.
    local = ["2026-10-25 02:59:55", "2026-10-25 02:00:00"]
    with pytest.raises(ValueError, match="daylight saving"):
        mpmpp.load_data(write(tmp_path / "d.csv", df.iloc[:2], local), model())


def test_a_model_free_read_takes_repeats_and_order_as_diagnose_does(tmp_path):
    """identify and stiction read the file before they know its sample time: a repeated row at
    an export's chunk boundary is dropped and noted there too (it used to stop identify with
    'time must be strictly increasing'), and rows out of order get diagnose's message."""
    from mpmpp.io import load_loop_data

    df = clean(20)
    back = load_loop_data(write(tmp_path / "d.csv", pd.concat([df.iloc[:10], df.iloc[9:]])), ["u", "y"])
    assert back.attrs["repairs"]["duplicates_dropped"] == 1
    np.testing.assert_array_equal(back.to_numpy(), df.to_numpy())
    with pytest.raises(ValueError, match=r"row 5, column time: 10 s is before row 4's 15 s"):
        load_loop_data(write(tmp_path / "d.csv", df.iloc[[0, 1, 3, 2, 4]]), ["u", "y"])


def test_status_and_text_columns(tmp_path):
    df = clean(40)
    df["status"] = np.where(np.arange(40) % 7 == 3, "Bad", "Good")
    df["tag"] = "FIC-101.PV"
    path = write(tmp_path / "d.csv", df)
    back = mpmpp.load_data(path, model(), quality_column="status")
    bad = np.arange(40) % 7 == 3
    assert list(back.columns) == ["time", "u", "y"]
    assert back.attrs["text_columns"] == ["tag"]
    assert back.attrs["repairs"]["bad_quality_rows"] == bad.sum()
    assert back["u"].isna().to_numpy().tolist() == bad.tolist()
    np.testing.assert_array_equal(back["y"][~bad], df["y"][~bad])
    # Without --quality-column a status column is just a text column: ignored, noted.
    plain = mpmpp.load_data(path, model())
    assert plain.attrs["text_columns"] == ["status", "tag"] and not plain["u"].isna().any()
    # Numeric codes: the user says which are good.
    df["status"] = np.where(bad, 0, 192)
    path = write(tmp_path / "d.csv", df.drop(columns="tag"))
    with pytest.raises(ValueError, match="say which are good"):
        mpmpp.load_data(path, model(), quality_column="status")
    coded = mpmpp.load_data(path, model(), quality_column="status", good_quality=["192"])
    assert coded["u"].isna().to_numpy().tolist() == bad.tolist()


def test_resample_block_averages_faster_data(tmp_path):
    fast = pd.DataFrame({"time": np.arange(100.0), "u": np.arange(100.0), "y": np.sin(np.arange(100.0))})
    back = mpmpp.load_data(write(tmp_path / "d.csv", fast), model(), resample_s=5)
    # Reference: NumPy block means.
    np.testing.assert_allclose(back["u"], fast["u"].to_numpy().reshape(20, 5).mean(axis=1), rtol=0, atol=1e-12)
    np.testing.assert_allclose(back["y"], fast["y"].to_numpy().reshape(20, 5).mean(axis=1), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(back["time"], 5.0 * np.arange(20))
    with pytest.raises(ValueError, match=r"sampled faster than 5 s \(see --resample\)|see --resample"):
        mpmpp.load_data(tmp_path / "d.csv", model())


def test_data_slower_than_the_model_is_an_error_not_a_half_empty_record(tmp_path):
    slow = clean()
    path = write(tmp_path / "slow.csv", slow, times=2 * TS * np.arange(len(slow)))
    with pytest.raises(ValueError, match=r"slow.csv: column time: samples are 10 s apart \(median\), slower than "
                                         r"the model's sample time of 5 s"):
        mpmpp.load_data(path, model())
    # One outage in regularly sampled data stays a gap, not this error.
    gappy = write(tmp_path / "gap.csv", slow, times=TS * np.r_[np.arange(100), np.arange(103, 203)])
    assert mpmpp.load_data(gappy, model())["u"].isna().sum() == 3


def test_past_the_data_names_its_span(tmp_path):
    df = clean()
    back = mpmpp.load_data(write(tmp_path / "d.csv", df, iso(df["time"])), model())
    clock = Clock.of(back, TS)
    with pytest.raises(ValueError, match=r"--train-end 2h \(2.00 h from the start\) is outside the data: "
                                         r".*d.csv spans 2026-03-29T01:30:00\+01:00 .. 2026-03-29T01:46:40\+01:00"):
        clock.when("2h")
    with pytest.raises(ValueError, match="outside the data"):
        clock.when("2026-03-29T00:00:00Z")
    plain = Clock.of(mpmpp.load_data(write(tmp_path / "s.csv", df), model()), TS)
    with pytest.raises(ValueError, match="has no timestamps"):
        plain.when("2026-03-29T00:00:00Z")


def test_complete_runs_cut_at_missing_values_and_time_gaps():
    from mpmpp.signals import complete_runs, longest_run

    valid = np.array([1, 1, 1, 0, 1, 1, 1, 1, 1, 1], bool)
    assert complete_runs(valid) == [(0, 3), (4, 10)]
    assert complete_runs(valid, starts=[2, 3, 6]) == [(0, 2), (2, 3), (4, 6), (6, 10)]
    assert longest_run(valid, starts=[6]) == (6, 10) and longest_run(np.zeros(4, bool)) == (0, 0)


def test_a_data_frame_with_rows_left_out_gets_a_segment_break_there():
    """diagnose / compare through the Python API: the rows a historian left out are not taken
    as the next sample (the file path puts them on the grid as missing rows)."""
    from mpmpp.signals import extract

    model = mpmpp.Model.from_json(json.dumps({"name": "m", "sample_time_s": 10.0, "inputs": ["u"], "outputs": ["y"],
                                              "process": {"y": {"u": {"num": [0.5], "den": [1.0, -0.5], "delay": 1}}}}),
                                  "test")
    t = 10.0 * np.r_[np.arange(300), np.arange(305, 605)]
    rng = np.random.default_rng(0)
    data = pd.DataFrame({"time": t, "u": rng.normal(size=600), "y": rng.normal(size=600)})
    assert extract(model, data, min_segment=50).segments == [(0, 300), (300, 600)]


def test_status_words_in_a_numeric_column_are_missing_and_noted(tmp_path):
    """A historian writes words in place of values ("Bad Input", "I/O Timeout"): they are
    missing values, counted per column and named in the note every command prints."""
    df = clean(40)
    u = df["u"].map("{:.6g}".format).to_numpy(dtype=object)
    u[[5, 17]] = ["Bad Input", "I/O Timeout"]
    path = write(tmp_path / "d.csv", df.assign(u=u))
    back = mpmpp.load_data(path, model())
    assert back["u"].isna().to_numpy().nonzero()[0].tolist() == [5, 17]
    np.testing.assert_allclose(back["y"], df["y"], rtol=1e-6)
    assert back.attrs["repairs"]["status_words"] == [{"column": "u", "cells": 2, "first": "Bad Input"}]
    assert repair_lines(back.attrs["repairs"]) == [
        "column u: 2 status word(s) read as missing (the first 'Bad Input')"]
    # read as written (identify, stiction): the same
    assert mpmpp.load_data(path).attrs["repairs"]["status_words"][0]["cells"] == 2


@pytest.mark.parametrize("ts, jitter", [(10.0, 1.0), (1.0, 0.2), (0.5, 0.05), (15.0, 2.0), (7.3, 0.0)])
def test_the_sample_time_of_jittered_timestamps_is_the_nominal_one(ts, jitter):
    """Without a model the grid comes from the file: 2,000 timestamps jittered by up to a tenth
    or a fifth of a sample, three rows left out. The median step can be off the nominal value
    (a hundredth of a sample drifts the end of the record a whole sample off the grid); the
    sample time is the nominal one."""
    from mpmpp.io import sample_time_of

    rng = np.random.default_rng(int(ts * 10))
    t = np.delete(ts * np.arange(2000) + rng.uniform(-jitter, jitter, 2000), [100, 101, 102])
    assert sample_time_of(t) == ts and sample_time_of(t[:1]) == 0.0


def test_a_model_free_command_reads_a_historian_export_as_diagnose_does(tmp_path, capsys):
    """identify on an export with jittered calendar timestamps, status words, a bad-quality row
    and a hole longer than --max-gap: the rows go on the 10 s grid as diagnose puts them (noted
    on stderr), and the model is the one identified from the clean frame with the same rows
    missing."""
    import sys

    sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
    import pi_loop
    from mpmpp.cli import main
    from mpmpp.model_identification import model_from_data

    df = pi_loop.simulate(pi_loop.FLOW, seed=5, rows=1500, setpoint_steps=True)
    rng = np.random.default_rng(3)
    start = datetime(2026, 3, 1, 6, 0, tzinfo=timezone.utc)
    stamps = [(start + timedelta(seconds=float(s) + rng.uniform(-1.0, 1.0))).isoformat(timespec="milliseconds")
              for s in df["time"]]
    export = df.astype(object).assign(time=stamps, quality="Good")
    export.loc[300, "PV"] = "Bad Input"
    export.loc[700:711, "OP"] = "I/O Timeout"
    export.loc[450, "quality"] = "Bad"
    export = export.drop(index=range(1000, 1030))         # 5 min the historian left out
    write(tmp_path / "loop.csv", export)
    assert main(["identify", str(tmp_path / "loop.csv"), "--inputs", "OP", "--outputs", "PV", "--quality-column",
                 "quality", "--max-gap", "2min", "-o", str(tmp_path / "m.json"), "--json"]) == 0
    out, err = capsys.readouterr()
    assert "timestamp(s) snapped to the sample grid" in err and "1 gap(s) longer than --max-gap split" in err
    assert "1 row(s) of bad quality made missing" in err
    doc = json.loads(out)
    expected = df.copy()
    expected.loc[300, "PV"] = np.nan          # a lost PV sample alone: interpolated either way
    expected.loc[[450, *range(700, 712)], ["OP", "PV"]] = np.nan
    expected = expected.drop(index=range(1000, 1030))
    r = model_from_data(expected, ["OP"], ["PV"])
    assert doc["rows_used"] == r.rows_used and doc["interpolated_samples"] == r.interpolated_samples == 1
    assert doc["channels"][0]["gain"] == pytest.approx(r.channels[0].gain, rel=1e-9)
    assert doc["channels"][0]["time_constant_s"] == pytest.approx(r.channels[0].time_constant_s, rel=1e-9)
