"""Detector: indicator/alarms against a plain NumPy eq. 23, file round trip, JSON shape,
a short end-to-end run on a simulated SISO loop, and the Monte Carlo on a Dask LocalCluster."""
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mpmpp
from mpmpp import _core
from mpmpp.detect import Detector, detect, make_config
from child_process import child_env

TF = mpmpp.TransferFunction


def numpy_indicator(scores, n_T):
    """Eq. 23: share of negative scores among the last n_T windows (earlier windows absent)."""
    neg = (np.asarray(scores) < 0).astype(float)  # NaN < 0 is False: a skipped window is not negative
    return np.array([neg[max(0, t - n_T + 1):t + 1].sum() / n_T for t in range(len(neg))])


def numpy_alarm_starts(indicator, s_T):
    above = indicator >= s_T
    return [t for t in range(len(above)) if above[t] and (t == 0 or not above[t - 1])]


@pytest.mark.parametrize("n_T,s_T", [(24, 0.95), (5, 0.6), (1, 1.0), (10, 0.3)])
def test_indicator_and_alarms_match_numpy(n_T, s_T):
    rng = np.random.default_rng(n_T)
    # Blocks of mostly-negative and mostly-positive scores, with zeros (training) and NaN (skipped).
    scores = rng.normal(0, 1, 600) + np.repeat(rng.choice([-2.0, 1.5], 12), 50)
    scores[rng.choice(600, 30, replace=False)] = np.nan
    scores[:40] = 0.0
    cfg = mpmpp.DetectorConfig()
    cfg.step_s, cfg.inspection_s, cfg.threshold = 300.0, 300.0 * n_T, s_T
    ind = _core.MismatchIndicator(cfg.inspection_windows(), cfg.alarm_count())
    got = [ind.push(float(s)) for s in scores]
    ref = numpy_indicator(scores, n_T)
    np.testing.assert_array_equal([g[0] for g in got], ref)
    assert [t for t, g in enumerate(got) if g[2]] == numpy_alarm_starts(ref, s_T)
    assert [g[1] for g in got] == list(ref >= s_T)


def test_config_presets_and_errors(tmp_path):
    siso, mimo = make_config("paper_siso"), make_config("paper_mimo")
    assert (siso.arx_order_a, mimo.arx_order_a, mimo.arx_order_b) == (9, 18, 10)
    assert siso.window_samples(5.0) == 1440 and siso.inspection_windows() == 24
    assert (siso.alpha, mimo.alpha) == (1.5, 1.5)  # Tables 1 and 3 verbatim
    rec_siso, rec_mimo = make_config("siso"), make_config("mimo")
    assert rec_siso.arx_order_a == 9 and rec_mimo.arx_order_a == 18
    assert make_config(None).to_json() == rec_siso.to_json()  # the recommended preset is the default
    p = tmp_path / "cfg.json"
    p.write_text(json.dumps({"preset": "paper_mimo", "alpha": 3.0}))
    assert make_config(str(p)).alpha == 3.0
    with pytest.raises(ValueError, match="alpah"):
        make_config({"alpah": 1})
    with pytest.raises(ValueError, match="threshold"):
        make_config({"threshold": 2})


def siso_data(seed, hours=7.0, gain_change_h=None):
    """A small closed loop (the paper's SISO plant under the MPC), optionally with a gain change."""
    scen = mpmpp.scenarios.paper_siso()
    scen["duration_s"] = hours * 3600
    scen["events"] = [] if gain_change_h is None else [
        {"time_s": gain_change_h * 3600, "type": "gain", "output": "dry_weight", "input": "stock_flow",
         "factor": 2.0}]
    from mpmpp.evaluate import nominal_model

    return nominal_model(scen), mpmpp.simulate(scen, seed=seed)


# The fixture's config (the earlier default): 3 h of training, alpha 8.
TRAINED_CONFIG = {"preset": "paper_siso", "alpha": 8.0}


@pytest.fixture(scope="module")
def trained():
    model, data = siso_data(3, hours=7.5, gain_change_h=4.0)
    result, detector = detect(model, data, 3 * 3600, TRAINED_CONFIG, return_detector=True)
    return model, data, result, detector


def test_end_to_end_gain_change_alarms_after_change_only(trained):
    model, data, result, _ = trained
    starts = result.alarm_starts(0)  # G[dry_weight <- stock_flow]
    assert starts.size >= 1 and starts.min() >= 4 * 3600
    assert result.alarm_starts(1).size == 0  # the noise model never changed
    # Training windows score 0, later windows are scored.
    tr = result.windows["training"].to_numpy()
    assert np.all(result.scores[tr] == 0) and np.all(result.scores[~tr] != 0)
    # Indicator = eq. 23 over the scores.
    for k in range(result.scores.shape[1]):
        np.testing.assert_array_equal(result.indicator[:, k], numpy_indicator(result.scores[:, k], 24))


def test_json_shape(trained):
    _, _, result, _ = trained
    d = json.loads(json.dumps(result.to_dict()))
    assert set(d) >= {"train_end_s", "channels", "windows", "alarms"}
    assert d["channels"] == [{"kind": "process", "output": "dry_weight", "input": "stock_flow"},
                             {"kind": "noise", "output": "dry_weight"}]
    w = d["windows"][0]
    assert set(w) == {"start_s", "end_s", "scores", "indicator"} and len(w["scores"]) == 2
    assert w["end_s"] - w["start_s"] == 7200.0 and w["scores"] == [0.0, 0.0]
    for a in d["alarms"]:
        assert set(a) <= {"kind", "output", "input", "start_s"} and a["kind"] in ("process", "noise")


def test_nan_windows_are_skipped_and_reported(trained):
    """150 missing rows: the windows that lose more than a tenth of their 1440 rows to them are
    skipped; a window does without fewer (fitted on its complete rows)."""
    model, data, _, detector = trained
    gap = data.copy()
    gap.loc[5000:5149, "dry_weight"] = np.nan
    r = detector.monitor(gap)
    skipped = r.windows["skipped"].to_numpy()
    first = r.windows["first"].to_numpy()
    expect = np.minimum(first + 1440, 5150) - np.maximum(first, 5000) > 144
    assert expect.any() and (~expect & (first <= 5149) & (first + 1440 > 5000)).any()
    np.testing.assert_array_equal(skipped, expect)
    assert np.isnan(r.scores[skipped & ~r.windows["training"].to_numpy()]).all()
    assert len(r.to_dict()["skipped_windows"]) == expect.sum()


def test_a_break_in_the_time_axis_skips_the_windows_across_it(trained):
    """Ten rows left out of the record (its time jumps 11 samples) is a break, not lost samples:
    exactly the windows that span the jump are skipped, with that reason; the same rows kept as
    missing values on the regular grid are lost samples, and a jittered time axis is no break."""
    model, data, _, detector = trained
    ts = model.sample_time_s
    jumped = data.drop(index=range(5000, 5010)).reset_index(drop=True)
    r = detector.monitor(jumped)
    first = r.windows["first"].to_numpy()
    across = (first < 5000) & (first + 1440 > 5000)
    np.testing.assert_array_equal(r.windows["skipped"].to_numpy(), across)
    assert set(r.windows["skip_reason"][across]) == {"a break between segments in the window"}
    lost = data.copy()
    lost.loc[5000:5009, [c for c in data.columns if c != "time"]] = np.nan
    assert not detector.monitor(lost).windows["skipped"].any()
    jittered = data.copy()
    jittered["time"] += np.random.default_rng(0).uniform(-0.2, 0.2, len(data)) * ts
    assert not detector.monitor(jittered).windows["skipped"].any()


def test_json_writer_carries_the_result_tables(trained, tmp_path):
    """The C++ writer (detector_io) against the Python tables it formats: every kept window's
    times, scores and indicator, every skipped window with its reason, every alarm."""
    model, data, _, detector = trained
    gap = data.copy()
    gap.loc[5000:5149, "dry_weight"] = np.nan
    r = detector.monitor(gap)
    d = r.to_dict()
    keep = ~r.windows["skipped"].to_numpy(bool)
    assert [(w["start_s"], w["end_s"]) for w in d["windows"]] == list(
        zip(r.windows["start_s"][keep], r.windows["end_s"][keep]))
    np.testing.assert_array_equal(np.array([w["scores"] for w in d["windows"]]), r.scores[keep])
    np.testing.assert_array_equal(np.array([w["indicator"] for w in d["windows"]]), r.indicator[keep])
    assert [(w["start_s"], w["reason"]) for w in d["skipped_windows"]] == list(
        zip(r.windows["start_s"][~keep], r.windows["skip_reason"][~keep]))
    assert d["alarms"] == [{k: v for k, v in a.items() if k != "channel"} for a in r.alarms]
    assert (d["train_end_s"], d["threshold"], d["channels"]) == (r.train_end_s, r.threshold, r.channels)
    path = tmp_path / "detect.json"
    r.save_json(path)
    assert json.loads(path.read_text()) == d


def test_save_load_new_process_identical_scores(trained, tmp_path):
    model, data, result, detector = trained
    path = tmp_path / "detector.json"
    detector.save(path)
    csv = tmp_path / "data.csv"
    mpmpp.save_data(csv, data)
    script = (
        "import json, sys, numpy as np, mpmpp\n"
        "from mpmpp.detect import Detector\n"
        f"d = Detector.load({str(path)!r})\n"
        f"r = d.monitor(mpmpp.load_data({str(csv)!r}, d.model))\n"
        "print(json.dumps({'scores': r.scores.tolist(), 'alarms': r.to_dict()['alarms']}))\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True,
                         env=child_env())
    got = json.loads(out.stdout)
    np.testing.assert_array_equal(np.array(got["scores"]), result.scores)  # bit-identical
    assert got["alarms"] == result.to_dict()["alarms"]
    # Round trip of the file itself is exact.
    assert Detector.load(path)._core.to_json() == detector._core.to_json()


def test_corrupt_and_truncated_detector_files_are_clear_errors(trained, tmp_path):
    _, _, _, detector = trained
    path = tmp_path / "d.json"
    detector.save(path)
    text = path.read_text()
    bad = tmp_path / "bad.json"
    bad.write_text(text[: len(text) // 2])
    with pytest.raises(ValueError, match="truncated or corrupt"):
        Detector.load(bad)
    doc = json.loads(text)
    doc["version"] = 99
    bad.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match="version 99"):
        Detector.load(bad)
    doc = json.loads(text)
    del doc["channels"][0]["svm"]["offset"]
    bad.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=r"channels\[0\]\.svm: missing field 'offset'"):
        Detector.load(bad)
    with pytest.raises(ValueError, match="cannot read"):
        Detector.load(tmp_path / "absent.json")


def test_too_short_training_is_an_error():
    model, data = siso_data(0, hours=5.0)
    with pytest.raises(ValueError, match="train_end_s"):
        detect(model, data, 2 * 3600 + 60, "paper_siso")


def test_cli_detect_json(trained, tmp_path):
    model, data, result, _ = trained
    mpmpp.save_model(model, tmp_path / "m.json")
    mpmpp.save_data(tmp_path / "d.csv", data)
    from mpmpp.cli import main

    import contextlib
    import io

    (tmp_path / "cfg.json").write_text(json.dumps(TRAINED_CONFIG))
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["detect", str(tmp_path / "m.json"), str(tmp_path / "d.csv"), "--train-end", "10800",
                     "--config", str(tmp_path / "cfg.json"),
                     "--json", "--save-detector", str(tmp_path / "det.json")])
    assert code == 0
    d = json.loads(buf.getvalue())
    assert d["alarms"] == result.to_dict()["alarms"]
    assert (tmp_path / "det.json").exists()
    assert main(["detect", str(tmp_path / "m.json"), str(tmp_path / "d.csv"), "--train-end", "-5"]) == 2


def test_written_detector_version_is_the_documented_current_one(trained, tmp_path):
    """docs/formats.md's table of versioned files and CHANGELOG.md name the version a saved
    detector carries (docs/formats.md once said 4 while files said 6)."""
    _, _, _, detector = trained
    path = tmp_path / "d.json"
    detector.save(path)
    version = json.loads(path.read_text())["version"]
    root = Path(__file__).resolve().parents[2]
    table = re.search(r"\| `mpmpp-detector` \| (\d+) \|", (root / "docs" / "formats.md").read_text())
    current = re.search(r"Version (\d+) is current \(`Detector::kFormatVersion`\)",
                        (root / "CHANGELOG.md").read_text())
    assert int(table.group(1)) == version and int(current.group(1)) == version


def test_lost_samples_cost_no_window_under_the_papers_presets_either():
    """The paper's SISO record (seed 0) with one PV sample lost every hour and one OP sample
    every three: the per-window ARX-OE fits each window's complete rows as stretches, so no
    window is skipped (before, the training period kept no window and detect refused), and
    the first noise and MPM alarms start within 15 minutes of the complete record's."""
    from mpmpp.evaluate import load_scenario, nominal_model
    from mpmpp.simulate import simulate

    scenario = load_scenario("paper_siso")
    model = nominal_model(scenario)
    data = simulate(scenario, seed=0)
    lost = data.copy()
    hour = int(3600 / model.sample_time_s)
    lost.loc[lost.index[hour // 2::hour], "dry_weight"] = np.nan
    lost.loc[lost.index[hour // 3::3 * hour], "stock_flow"] = np.nan
    complete, gapped = detect(model, data, None, "paper_siso"), detect(model, lost, None, "paper_siso")
    assert not gapped.windows["skipped"].any()
    for kind in ("noise", "process"):
        first = [min(a["start_s"] for a in r.to_dict()["alarms"] if a["kind"] == kind) for r in (complete, gapped)]
        assert abs(first[0] - first[1]) <= 900.0
