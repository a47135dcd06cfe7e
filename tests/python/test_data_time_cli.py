"""Every command reads --train-end the same way and reports the same times.

One closed-loop record (the gain doubles at 8 h) is written three ways: seconds from 0,
ISO-8601 timestamps across a daylight-saving change, and Unix epoch seconds. detect,
diagnose, compare, update and check must give the same results on all three, name the
same instants, and read --train-end as a duration, seconds or a timestamp alike."""
import json
from datetime import datetime, timedelta, timezone

import pytest

from closed_loop_case import simulate
from closed_loop_case import model as loop_model

import mpmpp
from mpmpp.cli import main

START = datetime(2026, 3, 28, 21, 0, tzinfo=timezone.utc)   # +01:00 until 2026-03-29 01:00 UTC
TRAIN_END_H = 6.0


def zoned(t_s):
    t = START + timedelta(seconds=float(t_s))
    offset = 2 if t >= datetime(2026, 3, 29, 1, tzinfo=timezone.utc) else 1
    return (t + timedelta(hours=offset)).replace(tzinfo=None).isoformat() + f"+0{offset}:00"


def instant(text):
    return datetime.fromisoformat(text.replace("Z", "+00:00")).astimezone(timezone.utc)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("time")
    mpmpp.save_model(loop_model(), d / "model.json")
    df = simulate(n=11520, seed=4, onset=5760, gain=2.0)          # 16 h, the gain doubles at 8 h
    out = {}
    for kind, times in [("seconds", df["time"]), ("zoned", [zoned(t) for t in df["time"]]),
                        ("epoch", START.timestamp() + df["time"])]:
        path = d / f"{kind}.csv"
        df.assign(time=times).to_csv(path, index=False)
        out[kind] = str(path)
    out["model"] = str(d / "model.json")
    out["dir"] = d
    return out


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def run_json(capsys, *argv):
    code, out, err = run(capsys, *argv, "--json")
    assert code == 0, err
    return json.loads(out)


TRAIN_END = {"seconds": f"{TRAIN_END_H}h", "zoned": zoned(TRAIN_END_H * 3600), "epoch": str(int(TRAIN_END_H * 3600))}


def test_every_command_agrees_on_times(files, capsys):
    docs = {}
    for kind in ("seconds", "zoned", "epoch"):
        args = [files["model"], files[kind]]
        docs[kind] = {
            "detect": run_json(capsys, "detect", *args, "--train-end", TRAIN_END[kind]),
            "diagnose": run_json(capsys, "diagnose", *args, "--train-end", TRAIN_END[kind]),
            "compare": run_json(capsys, "compare", *args),
            "check": run_json(capsys, "check", *args),
            "update": run_json(capsys, "update", *args, "--train-end", TRAIN_END[kind], "--apply", "F1",
                               "-o", files["dir"] / f"updated_{kind}.json"),
        }
    seconds, zoned_doc, epoch = docs["seconds"], docs["zoned"], docs["epoch"]
    # The same numbers whatever the time format.
    for name in ("detect", "diagnose", "compare", "update"):
        for other in (zoned_doc, epoch):
            assert strip_stamps({**other[name], "model": None}) == strip_stamps({**seconds[name], "model": None}), name
    assert seconds["detect"]["alarms"], "the gain change must raise an alarm"
    assert seconds["diagnose"]["findings"], "the gain change must be found"
    # Calendar files name the same instants; the seconds file has none to name.
    for name, key, point in [("detect", "alarms", "start"), ("diagnose", "findings", "onset"),
                             ("update", "errors", "onset")]:
        assert seconds[name][key]
        for a, b, c in zip(seconds[name][key], zoned_doc[name][key], epoch[name][key]):
            assert point not in a
            assert instant(b[point]) == instant(c[point]) == START + timedelta(seconds=a[f"{point}_s"])
    assert zoned_doc["check"]["data"]["time"]["start"] == "2026-03-28T22:00:00+01:00"
    assert instant(epoch["check"]["data"]["time"]["end"]) == instant(zoned_doc["check"]["data"]["time"]["end"])
    assert zoned_doc["detect"]["time"]["kind"] == "calendar" and seconds["detect"]["time"]["kind"] == "seconds"


def strip_stamps(doc):
    """The document without the time block and the timestamps beside the *_s fields."""
    if isinstance(doc, list):
        return [strip_stamps(x) for x in doc]
    if isinstance(doc, dict):
        return {k: strip_stamps(v) for k, v in doc.items()
                if k != "time" and not (f"{k}_s" in doc and isinstance(v, str))}
    return doc


def test_train_end_reads_the_same_in_every_form(files, capsys):
    args = [files["model"], files["zoned"]]
    forms = ["6h", "360min", "21600", zoned(21600), "2026-03-29T03:00:00Z"]
    found = [run_json(capsys, "diagnose", *args, "--train-end", f)["findings"] for f in forms]
    assert all(f == found[0] for f in found)


def test_summaries_name_times_in_the_data_time(files, capsys):
    code, out, _ = run(capsys, "detect", files["model"], files["zoned"], "--train-end", "6h")
    assert code == 0
    doc = run_json(capsys, "detect", files["model"], files["zoned"], "--train-end", "6h")
    assert "trained on 2026-03-28T22:00:00+01:00 .. 2026-03-29T05:00:00+02:00 (6 h)" in out
    assert doc["alarms"][0]["start"] in out
    code, out, _ = run(capsys, "diagnose", files["model"], files["zoned"], "--train-end", "6h")
    onset = run_json(capsys, "diagnose", files["model"], files["zoned"], "--train-end", "6h")["findings"][0]
    assert onset["onset_s"] > 0 and f"since {onset['onset']}" in out
    code, out, _ = run(capsys, "detect", files["model"], files["seconds"], "--train-end", "6h")
    assert "trained on 0.00 h .. 6.00 h (6 h)" in out


@pytest.mark.parametrize("command", ["detect", "diagnose", "update"])
def test_train_end_past_or_at_the_end_is_a_clear_error(files, capsys, command):
    extra = ["--apply", "F1", "-o", str(files["dir"] / "new.json")] if command == "update" else []
    for when, message in [("20h", "is outside the data: " + files["zoned"] +
                           " spans 2026-03-28T22:00:00+01:00 .. 2026-03-29T15:00:00+02:00 (16 h)"),
                          ("2026-03-30T00:00:00Z", "is outside the data"),
                          ("15.9h", "h of data after it")]:
        code, out, err = run(capsys, command, files["model"], files["zoned"], "--train-end", when, *extra)
        assert code == 2 and out == ""
        lines = err.strip().splitlines()
        assert len(lines) == 1 and message in lines[0], err
    assert not (files["dir"] / "new.json").exists()


def test_check_lists_every_repair_and_commands_note_them(files, capsys):
    lines = open(files["zoned"]).read().splitlines()
    header, rows = lines[0], lines[1:]
    rows[10] = rows[10].replace(":50+", ":50.003+")                 # 3 ms late
    rows = rows[:21] + rows[20:100] + rows[103:]      # a repeated row, a 20 s gap
    text = [header + ",status"] + [r + (",Bad" if k == 50 else ",Good") for k, r in enumerate(rows)]
    path = files["dir"] / "export.csv"
    path.write_text("\n".join(text) + "\n")
    code, out, err = run(capsys, "check", files["model"], path, "--quality-column", "status")
    assert code == 0, err
    assert "repaired: 1 timestamp(s) snapped to the sample grid (largest move 0.003 s)" in out
    assert "repaired: 1 repeated row(s) dropped (same time, same values)" in out
    assert "repaired: 1 row(s) of bad quality made missing" in out
    assert "repaired: gap 2026-03-28T22:08:15+01:00 .. 2026-03-28T22:08:35+01:00 (20 s between samples): " \
           "3 missing row(s) added" in out
    code, out, err = run(capsys, "compare", files["model"], path)
    assert code == 0
    assert err.startswith(f"note: {path}: ") and "text column(s) ignored (no numbers): status" in err
    code, out, err = run(capsys, "check", files["model"], path, "--max-gap", "10s")
    assert "record split, a new segment starts" in out and "2 segments" in out


def test_too_short_a_record_is_a_clear_error(files, capsys):
    short = files["dir"] / "short.csv"
    # below the 150 rows every analysis needs (diagnose scales its segments to longer records)
    short.write_text("\n".join(open(files["zoned"]).read().splitlines()[:121]) + "\n")
    for argv in (["detect", "--train-end", "10min"], ["diagnose"], ["update", "--apply", "F1", "-o", "x.json"]):
        code, out, err = run(capsys, argv[0], files["model"], short, *argv[1:])
        assert code == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
        assert "too few" in err or "leaves" in err or "too short: 120 rows" in err


def test_commands_run_across_a_split_record(files, capsys):
    """A 1 h outage at 10 h (longer than --max-gap): every command works on the two segments."""
    lines = open(files["zoned"]).read().splitlines()
    path = files["dir"] / "outage.csv"
    path.write_text("\n".join(lines[:1 + 7200] + lines[1 + 7920:]) + "\n")
    args = [files["model"], path]
    check = run_json(capsys, "check", *args)["data"]
    assert check["segments"] == 2 and [g["split"] for g in check["repairs"]["gaps"]] == [True]
    assert check["repairs"]["gaps"][0]["start"] == "2026-03-29T08:59:55+02:00"   # the last sample before
    detect = run_json(capsys, "detect", *args, "--train-end", "6h")
    assert detect["skipped_windows"] and detect["alarms"]
    # No window used spans the break (the missing row at 10 h).
    assert not [w for w in detect["windows"] if w["start_s"] <= 36000 < w["end_s"]]
    for command, extra in [("diagnose", []), ("compare", []),
                           ("update", ["--apply", "F1", "-o", files["dir"] / "outage_model.json"])]:
        code, out, err = run(capsys, command, *args, *(["--train-end", "6h"] if command != "compare" else []),
                             *extra)
        assert code == 0, err
        assert "split the record" in err
