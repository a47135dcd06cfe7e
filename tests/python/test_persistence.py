"""Nothing a user saved is lost or half-written.

- load-save-load of a model and of a data file is exact (bit for bit, awkward floats included);
- a truncated or corrupted file gives a one-line ValueError, never a partial object;
- kill-during-write: a child process rewrites a large model (or data) file in a loop and is
  SIGKILLed while a write is in flight (we wait until its temporary file exists); the file
  must still be one complete version, never a torn mixture or a truncated one;
- atomic_output (files written in Python) leaves the old file on an exception.
"""
import os
import re
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pandas as pd
import pytest

import mpmpp
from mpmpp.io import atomic_output
from child_process import child_env

# the largest data value is the one just below 1e100 (a file holds nothing larger, data_io.hpp)
AWKWARD = [1 / 3, -2 / 7, 1e-300, 5e-324, float(np.nextafter(1e100, 0.0)), 0.1 + 0.2, -0.0]


def awkward_model(fir_length=3, scale=1.0):
    TF = mpmpp.TransferFunction
    taps = scale * np.sin(np.arange(1, fir_length + 1)) / np.arange(1, fir_length + 1)
    return mpmpp.Model("persist \u00e9 \u4e2d", 0.1 + 0.2, ["u1", "u2"], ["y"],
                       {"y": {"u1": TF(taps, [1.0], 3), "u2": TF([1 / 3, 1e-300], [1.0, -0.999], 0)}},
                       {"y": TF([1.0, -2 / 7], [1.0, 0.1 + 0.2])})


def test_model_load_save_load_exact(tmp_path):
    m = awkward_model()
    mpmpp.save_model(m, tmp_path / "a.json")
    a = mpmpp.load_model(tmp_path / "a.json")
    mpmpp.save_model(a, tmp_path / "b.json")
    assert a == m
    assert (tmp_path / "a.json").read_bytes() == (tmp_path / "b.json").read_bytes()
    g = a.process("y", "u2")
    assert g.num[0] == 1 / 3 and g.num[1] == 1e-300 and g.den[1] == -0.999 and a.sample_time_s == 0.1 + 0.2


def test_data_load_save_load_exact(tmp_path):
    values = np.array(AWKWARD * 3).reshape(-1, 3)
    df = pd.DataFrame({"time": np.arange(len(values)) * 0.5, "a": values[:, 0], "b": values[:, 1],
                       "c": np.where(np.arange(len(values)) % 2 == 0, np.nan, values[:, 2])})
    mpmpp.save_data(tmp_path / "a.csv", df)
    back = mpmpp.load_data(tmp_path / "a.csv")
    mpmpp.save_data(tmp_path / "b.csv", back)
    np.testing.assert_array_equal(back.to_numpy(), df.to_numpy())  # NaN == NaN here
    assert np.signbit(back["a"].to_numpy()).tolist() == np.signbit(df["a"].to_numpy()).tolist()
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()


@pytest.mark.parametrize("kind", ["model", "data"])
def test_truncated_or_corrupted_file_is_a_clear_error(tmp_path, kind):
    path = tmp_path / ("m.json" if kind == "model" else "d.csv")
    if kind == "model":
        mpmpp.save_model(awkward_model(), path)
        load = mpmpp.load_model
    else:
        mpmpp.save_data(path, pd.DataFrame({"time": [0.0, 1.0, 2.0], "a": [1.0, 2.0, 3.0]}))
        load = mpmpp.load_data
    text = path.read_bytes()
    bad = tmp_path / ("bad" + path.suffix)
    cuts = sorted({int(len(text) * f) for f in np.linspace(0, 0.97, 25)})
    for cut in cuts:
        bad.write_bytes(text[:cut])
        if kind == "data":
            # CSV cannot tell a cut file from a shorter one ("2,3" cut to "2," is a valid row
            # with a missing value): it is an error or a prefix whose rows before the last are
            # exact. (Our writer never leaves a cut file: see the kill-during-write test.)
            try:
                df = load(bad)
            except ValueError as exc:
                assert "\n" not in str(exc) and str(bad) in str(exc)
                continue
            original = load(path).to_numpy()
            assert len(df) <= len(original)
            np.testing.assert_array_equal(df.to_numpy()[:-1], original[:len(df) - 1])
            continue
        with pytest.raises(ValueError) as err:
            load(bad)
        assert "\n" not in str(err.value) and str(bad) in str(err.value)
    for corrupt in (b"\x00" * 64, text.replace(b"1", b"\xff", 1), text[:20] + b"\x1b[2J" + text[20:]):
        bad.write_bytes(corrupt)
        with pytest.raises(ValueError) as err:
            load(bad)
        assert "\n" not in str(err.value)


WRITER = textwrap.dedent("""
    import sys, numpy as np, pandas as pd, mpmpp
    sys.path.insert(0, sys.argv[3])
    from test_persistence import awkward_model, big_frame
    kind, path = sys.argv[1], sys.argv[2]
    versions = ([awkward_model(200000, 1.0), awkward_model(200000, 2.0)] if kind == "model"
                else [big_frame(1.0), big_frame(2.0)])
    save = mpmpp.save_model if kind == "model" else (lambda obj, p: mpmpp.save_data(p, obj))
    print("ready", flush=True)
    k = 0
    while True:
        save(versions[k % 2], path)
        k += 1
""")


def big_frame(scale):
    n = 100000
    return pd.DataFrame({"time": np.arange(n, dtype=float), "a": scale * np.sin(np.arange(n)) / 3,
                         "b": scale * np.cos(np.arange(n)) / 7})


@pytest.mark.parametrize("kind", ["model", "data"])
def test_kill_during_write_keeps_a_complete_file(tmp_path, kind):
    path = tmp_path / ("model.json" if kind == "model" else "data.csv")
    if kind == "model":
        versions = [awkward_model(200000, 1.0), awkward_model(200000, 2.0)]
        mpmpp.save_model(versions[0], path)
        load = mpmpp.load_model
    else:
        versions = [big_frame(1.0), big_frame(2.0)]
        mpmpp.save_data(path, versions[0])
        load = mpmpp.load_data
    env = child_env()
    killed_mid_write = 0
    for _ in range(2):
        child = subprocess.Popen([sys.executable, "-c", WRITER, kind, str(path), os.path.dirname(__file__)],
                                 stdout=subprocess.PIPE, env=env)
        try:
            assert child.stdout.readline().strip() == b"ready"
            deadline = time.monotonic() + 120
            # Kill as soon as a temporary file shows the child is between create and rename.
            while not any(name.startswith(f".{path.name}.tmp") for name in os.listdir(tmp_path)):
                assert time.monotonic() < deadline, "the writer never started a write"
                assert child.poll() is None, "the writer died on its own"
            child.send_signal(signal.SIGKILL)
            child.wait(timeout=60)
        finally:
            if child.poll() is None:
                child.kill()
                child.wait()
        leftovers = [n for n in os.listdir(tmp_path) if n.startswith(f".{path.name}.tmp")]
        killed_mid_write += bool(leftovers)
        loaded = load(path)  # a complete file of one of the two versions, never a mixture
        if kind == "model":
            assert loaded == versions[0] or loaded == versions[1]
        else:
            assert any(np.array_equal(loaded.to_numpy(), v.to_numpy()) for v in versions)
        for name in leftovers:  # what SIGKILL leaves behind is only ever a hidden temp file
            os.unlink(tmp_path / name)
    assert killed_mid_write >= 1, "no kill landed during a write: the test did not test anything"


def test_atomic_output_keeps_the_old_file_on_error(tmp_path):
    path = tmp_path / "scenario.json"
    path.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_output(path) as f:
            f.write("half of the new")
            raise RuntimeError("interrupted")
    assert path.read_text() == "old" and os.listdir(tmp_path) == ["scenario.json"]
    with atomic_output(path) as f:
        f.write("new")
    assert path.read_text() == "new" and os.listdir(tmp_path) == ["scenario.json"]


def test_atomic_output_into_a_missing_folder_names_the_file_asked_for(tmp_path):
    # the temporary file's name (".r.html.tmp.XXXX") was the one the user read
    path = tmp_path / "absent" / "r.html"
    with pytest.raises(FileNotFoundError, match=rf"^{re.escape(str(path))}: cannot write in .*absent: No such file"):
        with atomic_output(path) as f:
            f.write("x")
