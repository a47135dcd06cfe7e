"""The C++ streaming detector against the batch Python path on a paper-scenario
data set: the stream_csv example program (built C++, no Python inside) and the binding give
the batch `mpmpp detect --json` alarms and bit-identical scores."""
import glob
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

import mpmpp

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import make_stream_test_data as gen  # noqa: E402

COMMITTED = os.path.join(ROOT, "tests", "data", "stream")


def _stream_csv_binary():
    """The example program from MPMPP_BUILD_DIR or a build*/ folder of this checkout."""
    dirs = [os.environ["MPMPP_BUILD_DIR"]] if os.environ.get("MPMPP_BUILD_DIR") else sorted(
        glob.glob(os.path.join(ROOT, "build*")))
    for d in dirs:
        exe = os.path.join(d, "cpp", "examples", "stream_csv")
        if os.access(exe, os.X_OK):
            return exe
    return None


def _read_scores(path):
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    return lines[0], np.array([[float(c) if c else math.nan for c in line.split(",")] for line in lines[1:]])


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """Fresh data, Python-trained detector file and batch results (the committed data's recipe)."""
    out = str(tmp_path_factory.mktemp("stream"))
    gen.main(out)
    return out


def test_stream_csv_program_equals_batch_detect(generated, tmp_path):
    exe = _stream_csv_binary()
    if exe is None:
        pytest.skip("stream_csv is not built (configure with -DMPMPP_BUILD_TESTS=ON, or set MPMPP_BUILD_DIR)")
    alarms, scores = tmp_path / "alarms.csv", tmp_path / "scores.csv"
    run = subprocess.run([exe, os.path.join(generated, "detector.json"), os.path.join(generated, "data.csv"),
                          "--alarms-csv", str(alarms), "--scores-csv", str(scores)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    with open(os.path.join(generated, "batch.json"), encoding="utf-8") as f:
        batch = json.load(f)
    assert batch["alarms"], "the scenario must alarm for the comparison to mean something"
    assert alarms.read_text() == open(os.path.join(generated, "expected_alarms.csv")).read()
    # Alarms are printed as they occur, one line per start.
    assert sum(line.startswith("alarm ") for line in run.stdout.splitlines()) == len(batch["alarms"])
    header, got = _read_scores(scores)
    header_b, expected = _read_scores(os.path.join(generated, "expected_scores.csv"))
    assert header == header_b
    assert got.shape == expected.shape
    np.testing.assert_array_equal(got, expected)  # bit for bit, NaN (skipped) in the same places
    assert np.isnan(expected[:, 3]).sum() > 0


def test_stream_csv_trains_the_detector_python_trains(generated, tmp_path):
    """stream_csv --train (C++ alone) writes the detector file `mpmpp detect --save-detector`
    wrote for the same data and config, and the `detect --json` document of its windows."""
    exe = _stream_csv_binary()
    if exe is None:
        pytest.skip("stream_csv is not built (configure with -DMPMPP_BUILD_TESTS=ON, or set MPMPP_BUILD_DIR)")
    detector, result = tmp_path / "detector.json", tmp_path / "result.json"
    run = subprocess.run([exe, "--train", os.path.join(generated, "model.json"), "--train-end", str(gen.TRAIN_END_S),
                          "--config", "paper_siso", "--save-detector", str(detector), "--json", str(result),
                          os.path.join(generated, "data.csv")], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert detector.read_text() == open(os.path.join(generated, "detector.json")).read()
    with open(os.path.join(generated, "batch.json"), encoding="utf-8") as f:
        batch = json.load(f)
    with open(result, encoding="utf-8") as f:
        streamed = json.load(f)
    for key in ("train_end_s", "channels", "alarms", "threshold", "skipped_windows"):
        assert streamed[key] == batch[key], key
    bad = subprocess.run([exe, "--train", os.path.join(generated, "model.json"), os.path.join(generated, "data.csv")],
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "--train needs --train-end" in bad.stderr


def test_binding_stream_equals_batch_monitor(generated):
    detector = mpmpp.Detector.load(os.path.join(generated, "detector.json"))
    data = mpmpp.load_data(os.path.join(generated, "data.csv"), detector.model)
    batch = detector.monitor(data)
    stream = mpmpp.StreamingDetector(detector)
    time_s = data["time"].to_numpy()
    u, y = data[list(detector.model.inputs)].to_numpy(), data[list(detector.model.outputs)].to_numpy()
    half = len(time_s) // 3
    windows = [stream.push(t, uu, yy) for t, uu, yy in zip(time_s[:half], u[:half], y[:half])]
    windows = [w for w in windows if w is not None]
    windows += stream.push_block(time_s[half:], u[half:], y[half:])
    assert len(windows) == len(batch.windows)
    np.testing.assert_array_equal(np.array([w.scores for w in windows]), batch.scores)
    np.testing.assert_array_equal(np.array([w.indicator for w in windows]), batch.indicator)
    np.testing.assert_array_equal([w.skipped for w in windows], batch.windows["skipped"].to_numpy())
    starts = [(k, w.end_s) for w in windows for k in w.alarm_starts]
    assert starts == [(a["channel"], a["start_s"]) for a in batch.alarms]


def test_committed_test_data_matches_the_current_batch_path():
    """tests/data/stream feeds the C++ tests; its expectations must be what the batch path
    gives today for the committed detector and data."""
    detector = mpmpp.Detector.load(os.path.join(COMMITTED, "detector.json"))
    data = mpmpp.load_data(os.path.join(COMMITTED, "data.csv"), detector.model)
    result = detector.monitor(data)
    assert gen.scores_csv(result) == open(os.path.join(COMMITTED, "expected_scores.csv")).read()
    with open(os.path.join(COMMITTED, "batch.json"), encoding="utf-8") as f:
        batch = json.load(f)
    assert [{k: v for k, v in a.items() if k != "channel"} for a in result.alarms] == batch["alarms"]
    assert gen.alarms_csv(result) == open(os.path.join(COMMITTED, "expected_alarms.csv")).read()


def test_stream_errors_are_value_errors(generated):
    stream = mpmpp.StreamingDetector(os.path.join(generated, "detector.json"))
    assert stream.push(0.0, [1.0], [0.0]) is None
    with pytest.raises(ValueError, match="time_s: sample at 20 s comes 20 s after"):
        stream.push(20.0, [1.0], [0.0])
    with pytest.raises(ValueError, match="u: 2 values"):
        stream.push(5.0, [1.0, 2.0], [0.0])
    with pytest.raises(ValueError, match="detector: expected"):
        mpmpp.StreamingDetector(42)
    assert stream.samples == 1
