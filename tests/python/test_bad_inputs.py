"""Bad model and data files through the CLI: exit code 2, one line on stderr naming the
file and the field/column/row at fault, never a traceback."""
import copy
import json
import subprocess
import sys

import pytest


def good_model():
    return {
        "name": "bad-input test", "sample_time_s": 5.0, "inputs": ["u"], "outputs": ["y"],
        "process": {"y": {"u": {"num": [0.1], "den": [1.0, -0.9], "delay": 2}}},
        "noise": {"y": {"num": [1.0, -0.3], "den": [1.0, 0.5]}},
    }


GOOD_DATA = "time,u,y\n" + "".join(f"{5 * k},{k % 3},{0.1 * k}\n" for k in range(12))


def changed(edit):
    """The good model with one edit applied, as JSON text."""
    m = copy.deepcopy(good_model())
    edit(m)
    return json.dumps(m, indent=2)


def channel(m):
    return m["process"]["y"]["u"]


# (id, bad model text or None, bad data text or None, what the message must name)
CASES = [
    ("unknown top-level key", changed(lambda m: m.update(sampel_time_s=5.0)), None, "sampel_time_s: unknown key"),
    ("unknown channel key", changed(lambda m: channel(m).update(dleay=3)), None, "process.y.u.dleay: unknown key"),
    ("missing den", changed(lambda m: channel(m).pop("den")), None, 'process.y.u: missing field "den"'),
    ("missing sample time", changed(lambda m: m.pop("sample_time_s")), None, 'missing field "sample_time_s"'),
    ("num not an array", changed(lambda m: channel(m).update(num="0.1")), None, "process.y.u.num: must be an array"),
    ("coefficient too large", changed(lambda m: channel(m).update(num=[3e300])), None,
     "process.y.u.num[0]: too large to compute with, got 3e+300"),
    ("den[0] zero", changed(lambda m: channel(m).update(den=[0.0, 1.0])), None, "process.y.u: den[0] must be non-zero"),
    ("negative delay", changed(lambda m: channel(m).update(delay=-1)), None, "process.y.u.delay: must be >= 0"),
    ("fractional delay", changed(lambda m: channel(m).update(delay=2.5)), None, "process.y.u.delay: must be an integer"),
    ("empty inputs", changed(lambda m: m.update(inputs=[], process={})), None, "inputs: must name at least one"),
    ("duplicate output", changed(lambda m: m.update(outputs=["y", "y"])), None, 'outputs[1]: duplicate name "y"'),
    ("unknown input in channel", changed(lambda m: m["process"]["y"].update(w=channel(m))), None,
     'process.y.w: unknown input "w"'),
    ("noise not monic", changed(lambda m: m["noise"]["y"].update(num=[2.0, -0.3])), None, "noise.y: must be monic"),
    ("noise unstable", changed(lambda m: m["noise"]["y"].update(den=[1.0, -1.5])), None, "noise.y: unstable"),
    ("noise non-minimum-phase", changed(lambda m: m["noise"]["y"].update(num=[1.0, 2.0])), None,
     "noise.y: non-minimum-phase"),
    ("zero sample time", changed(lambda m: m.update(sample_time_s=0)), None, "sample_time_s: must be > 0"),
    ("wrong type sample time", changed(lambda m: m.update(sample_time_s="5")), None,
     "sample_time_s: must be a number, got string"),
    ("foptd negative time constant",
     changed(lambda m: m["process"]["y"].update(u={"gain": 1.0, "time_constant_s": -3.0, "dead_time_s": 0.0})),
     None, "process.y.u: time_constant_s must be >= 0"),
    ("line break in a name", changed(lambda m: m["process"].update({"y\nz": {}})), None,
     'process.y?z: unknown output "y?z"'),
    ("duplicate JSON key", '{"name": "a", "name": "b"}', None, "name: duplicate key"),
    ("model not JSON", "time,u,y\n0,1,2\n", None, "not valid JSON"),
    ("model empty", "", None, "file is empty"),
    ("model is a list", "[1, 2]", None, "top level: must be an object"),
    ("missing model column", None, GOOD_DATA.replace("time,u,y", "time,u,z"), 'column "y" (model output) is missing'),
    ("duplicate column", None, "time,u,y,u\n0,1,2,3\n5,1,2,3\n", 'duplicate column "u" (columns 2 and 4)'),
    ("non-numeric cell", None, "time,u,y\n0,1,2\n5,1,abc\n", 'row 3, column y: "abc" is not a number'),
    ("time repeated, other values", None, "time,u,y\n0,1,2\n5,1,2\n5,1,3\n",
     "row 4, column time: 5 s repeats row 3's time with different values"),
    ("time going back", None, "time,u,y\n0,1,2\n10,1,2\n5,1,2\n", "row 4, column time: 5 s is before row 3's 10 s"),
    ("off the sample grid", None, "time,u,y\n0,1,2\n5,1,2\n12,1,2\n", "row 4, column time: 12 s is 2 s off the 5 s"),
    ("sampled faster", None, "time,u,y\n0,1,2\n1,1,3\n5,1,2\n", "row 3, column time: 1 s falls on the same sample"),
    ("data empty", None, "", "file is empty"),
    ("data not CSV", None, json.dumps(good_model(), indent=2), "not a CSV file"),
    ("data binary", None, "\x00\x01PNG\x00", "not a CSV file (binary content)"),
    ("data separated by semicolons", None, "time;u;y\n0;1,5;2\n",
     "this row is separated by ';': save the file with ',' between fields and '.' as the decimal point"),
    ("data separated by tabs", None, "time\tu\ty\n0\t1.5\t2\n", "this row is separated by tabs"),
    ("no time column", None, "t,u,y\n0,1,2\n", 'row 1: no "time" column'),
    ("ragged row", None, "time,u,y\n0,1,2\n5,1\n", "row 3: 2 fields, the header has 3"),
    ("bad timestamp", None, "time,u,y\nyesterday,1,2\n", 'row 2, column time: "yesterday" is neither'),
    ("header only", None, "time,u,y\n", "no data rows"),
    ("infinite value", None, "time,u,y\n0,1,inf\n", 'row 2, column y: "inf" is not a number'),
    ("value too large to compute with", None, "time,u,y\n0,1,2\n5,3e300,2\n",
     'row 3, column u: "3e300" is too large to compute with'),
]


def run_check(*args):
    return subprocess.run([sys.executable, "-m", "mpmpp.cli", "check", *args],
                          capture_output=True, text=True, timeout=60)


def test_enough_distinct_cases():
    assert len({c[0] for c in CASES}) == len(CASES) >= 15


def test_the_good_pair_passes(tmp_path):
    (tmp_path / "model.json").write_text(json.dumps(good_model()))
    (tmp_path / "data.csv").write_text(GOOD_DATA)
    r = run_check(str(tmp_path / "model.json"), str(tmp_path / "data.csv"))
    assert r.returncode == 0, r.stderr
    assert "12 samples" in r.stdout


@pytest.mark.parametrize("name, model_text, data_text, fault", CASES, ids=[c[0] for c in CASES])
def test_bad_file_gives_one_line_naming_it(tmp_path, name, model_text, data_text, fault):
    model_path, data_path = tmp_path / "model.json", tmp_path / "data.csv"
    model_path.write_text(model_text if model_text is not None else json.dumps(good_model()))
    data_path.write_text(data_text if data_text is not None else GOOD_DATA)
    bad_file = model_path if model_text is not None else data_path
    r = run_check(str(model_path), str(data_path))
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == 1, r.stderr
    assert f"{bad_file}: " in lines[0]
    assert fault in lines[0]


def test_missing_file_names_it(tmp_path):
    r = run_check(str(tmp_path / "absent.json"))
    assert r.returncode == 2
    assert r.stderr.splitlines() == [f"mpmpp check: error: {tmp_path / 'absent.json'}: cannot read: "
                                     "No such file or directory"]
