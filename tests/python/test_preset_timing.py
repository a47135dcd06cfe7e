"""Detector presets resolved at the data's sample time (mpmpp.preset_timing): whole samples,
a window of at least MIN_WINDOW_SAMPLES, the paper's presets untouched at the paper's 5 s,
records at 7 s and 40 s accepted, too-short records and explicit bad values refused in one line."""
from __future__ import annotations

import contextlib
import io
import math

import pytest

import mpmpp
from mpmpp import DetectorConfig, families
from mpmpp.detect import detect, make_config
from mpmpp.evaluate import nominal_model
from mpmpp.preset_timing import MAX_WINDOW_SAMPLES, MIN_TRAINING_WINDOWS, MIN_WINDOW_SAMPLES, SINGLE_WINDOW_SIGNIFICANCE

PRESETS = ("siso", "mimo", "paper_siso", "paper_mimo")


class _Model:
    """make_config reads only the model's sample time and size."""

    def __init__(self, sample_time_s, outputs=("y",)):
        self.sample_time_s = sample_time_s
        self.outputs = list(outputs)


def _whole(x: float, unit: float) -> bool:
    k = round(x / unit)
    return k >= 1 and abs(x - k * unit) <= 1e-9 * x


@pytest.mark.parametrize("preset", PRESETS)
@pytest.mark.parametrize("ts", [1.0, 2.0, 7.0, 20.0, 40.0, 45.0, 60.0, 0.5])
def test_resolved_durations_are_whole_samples_and_keep_the_preset_proportions(preset, ts):
    nominal = DetectorConfig.preset(preset)
    c = make_config(preset, _Model(ts))
    for f in ("window_s", "step_s", "train_duration_s"):
        assert _whole(getattr(c, f), ts), (f, getattr(c, f))
    assert _whole(c.inspection_s, c.step_s)
    assert MIN_WINDOW_SAMPLES <= c.window_samples(ts) <= max(MAX_WINDOW_SAMPLES, c.step_samples(ts))
    # the same number of inspected windows (n_T, eq. 23); training: the preset's, and at least
    # MIN_TRAINING_WINDOWS windows, rounded up to a whole sample
    assert c.inspection_windows() == nominal.inspection_windows()
    needed = max(nominal.train_duration_s, MIN_TRAINING_WINDOWS * c.window_s)
    assert needed <= c.train_duration_s < needed + ts
    # a window that holds enough samples and not too many is only rounded
    if MIN_WINDOW_SAMPLES <= nominal.window_s / ts <= MAX_WINDOW_SAMPLES:
        assert abs(c.window_s - nominal.window_s) <= ts / 2
    elif nominal.window_s / ts > MAX_WINDOW_SAMPLES:
        assert c.window_samples(ts) == MAX_WINDOW_SAMPLES
        assert c.step_s == nominal.step_s and c.inspection_s == nominal.inspection_s
    else:
        assert c.window_samples(ts) == MIN_WINDOW_SAMPLES


@pytest.mark.parametrize("preset", PRESETS)
def test_presets_at_the_papers_sample_time_are_the_papers(preset):
    nominal = DetectorConfig.preset(preset)
    c = make_config(preset, _Model(5.0))
    assert c.to_json() == nominal.to_json()
    assert make_config({"preset": preset}, _Model(5.0)).to_json() == nominal.to_json()


def test_explicit_user_values_are_kept_and_still_checked():
    at_40 = _Model(40.0)
    kept = make_config({"preset": "siso", "window_s": 14400, "alpha": 3.0}, at_40)
    assert kept.window_s == 14400 and kept.alpha == 3.0
    assert kept.step_s == 320.0  # the preset's 300 s, to whole samples (not stretched: the window is the user's)
    assert kept.train_duration_s == 21600.0  # the preset's 6 h is already 1.5 such windows
    with pytest.raises(ValueError, match=r"^detector config: window_s = 7210\.0+ is not a positive whole number "
                                         r"of samples \(40\.0+\)$"):
        make_config({"preset": "siso", "window_s": 7210}, at_40).window_samples(40.0)
    # a config without a preset is the user's throughout: nothing is resolved
    plain = make_config({"window_s": 7200, "step_s": 300}, at_40)
    assert plain.step_s == 300
    with pytest.raises(ValueError, match="step_s = 300.* is not a positive whole number of samples"):
        plain.step_samples(40.0)
    # a DetectorConfig object is taken as it is
    assert make_config(DetectorConfig.siso(), at_40).window_s == 7200


def _record(ts: float, hours: float, seed: int = 1):
    """The paper's SISO loop (its dynamics in samples) recorded every ts seconds."""
    scen = mpmpp.scenarios.paper_siso()
    scen["sample_time_s"] = ts
    scen["duration_s"] = ts * math.floor(hours * 3600 / ts)
    scen["events"] = []
    return nominal_model(scen), mpmpp.simulate(scen, seed=seed)


@pytest.mark.parametrize("ts, hours", [(40.0, 17.0), (7.0, 8.5)])
def test_siso_preset_runs_at_40_s_and_7_s_and_says_what_it_resolved(ts, hours):
    model, data = _record(ts, hours)
    result, detector = detect(model, data, config="siso", return_detector=True)
    config = detector.config
    assert _whole(config.window_s, ts) and _whole(config.step_s, ts) and _whole(config.train_duration_s, ts)
    assert result.train_end_s == config.train_duration_s
    assert (~result.windows["training"]).sum() >= 1  # at least one monitored window
    note = [n for n in result.notes if n.startswith("preset siso")]
    assert len(note) == 1
    assert f"= {config.window_samples(ts)} samples" in note[0] and f"at {ts:g} s sampling" in note[0]


def test_a_too_short_record_is_one_line_saying_how_long_it_must_be():
    model, data = _record(40.0, 12.0)
    with pytest.raises(ValueError) as err:
        detect(model, data, config="siso")
    text = str(err.value)
    assert "\n" not in text
    # siso at 40 s: a 600-sample (6.667 h) window, 10 h of training (1.5 windows)
    assert text == ("data: the record spans 12 h; detection needs at least 16.67 h at 40 s sampling "
                    "(training 10 h plus one 6.667 h window); `compare` and `diagnose` judge a shorter record "
                    "without a training period")


def _cli_detect(tmp_path, ts: float, hours: float, *options) -> tuple[int, str]:
    """(exit code, stdout) of ``mpmpp detect`` on the paper SISO loop recorded every ts seconds."""
    from mpmpp.cli import main

    model, data = _record(ts, hours)
    mpmpp.save_model(model, tmp_path / "m.json")
    mpmpp.save_data(tmp_path / "d.csv", data)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["detect", str(tmp_path / "m.json"), str(tmp_path / "d.csv"), *options])
    return code, out.getvalue()


def test_cli_detect_at_40_s_reports_the_resolved_windows(tmp_path):
    from mpmpp.cli import main

    code, text = _cli_detect(tmp_path, 40.0, 17.0, "--train-end", "10h")
    assert code == 0
    assert "windows of 6.667 h every 16.67 min" in text
    assert "note: preset siso at 40 s sampling: window 6.667 h = 600 samples" in text
    err = io.StringIO()
    bad = tmp_path / "bad.json"
    bad.write_text('{"preset": "siso", "step_s": 300}')
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["detect", str(tmp_path / "m.json"), str(tmp_path / "d.csv"), "--train-end", "10h",
                     "--config", str(bad)])
    assert code == 2
    lines = err.getvalue().strip().splitlines()
    assert len(lines) == 1 and "step_s = 300" in lines[0] and "whole number of samples" in lines[0]



# --- fitting the durations to the record (preset_timing.fit_to_record) -------------------------

@pytest.mark.parametrize("family", [f.name for f in families.FAMILIES if f.record_hours[0] >= 10.0])
def test_records_the_presets_fit_are_left_alone(family):
    """Every family whose records are 10 h or more: the presets' durations stand as they are (so
    every earlier family and paper-scenario result is unchanged)."""
    for seed in range(3):
        spec, _ = families.family(family).draw(seed)
        model = nominal_model(spec)
        preset = "siso" if len(model.outputs) == 1 else "mimo"
        assert make_config(preset, model, spec["duration_s"]).to_json() == make_config(preset, model).to_json()
    for scen, presets in ((mpmpp.scenarios.paper_siso(), ("siso", "paper_siso")),
                          (mpmpp.scenarios.paper_mimo(), ("mimo", "paper_mimo"))):
        model = nominal_model(scen)
        for preset in presets:
            assert make_config(preset, model, scen["duration_s"]).to_json() == make_config(preset, model).to_json()


def test_a_short_record_trains_on_its_first_half_with_windows_that_fit():
    # siso at 5 s: 2 h windows (1440 samples) every 5 min, inspection 2 h, 6 h training, 3 pooled
    c = make_config("siso", _Model(5.0), record_s=4 * 3600)
    assert c.train_duration_s == 2 * 3600  # half the record
    assert c.window_s == 3600  # the 2 h monitored part holds MONITORED_WINDOWS = 2 windows
    assert c.step_s == 150 and c.inspection_s == 3600  # step scaled with the window, n_T kept
    assert c.inspection_windows() == DetectorConfig.preset("siso").inspection_windows()
    assert c.pooled_windows == 1 and c.window_significance == SINGLE_WINDOW_SIGNIFICANCE
    # 3 h at 1 s: half the record is 1.5 h, 1.5 windows of training: 1 h windows (3600 samples
    # would exceed the 2700-sample cap, the preset's 45 min window stands), so 1.5 h training
    c = make_config("siso", _Model(1.0), record_s=3 * 3600)
    assert c.window_s == 2700 and c.train_duration_s == 5400
    # the window never falls below MIN_WINDOW_SAMPLES: the training grows to 1.5 of them instead
    c = make_config("siso", _Model(5.0), record_s=2.2 * 3600)
    assert c.window_samples(5.0) == MIN_WINDOW_SAMPLES
    assert c.train_duration_s == MIN_TRAINING_WINDOWS * MIN_WINDOW_SAMPLES * 5.0


def test_what_the_user_set_is_kept_when_fitting():
    at_5 = _Model(5.0)
    c = make_config({"preset": "siso", "window_s": 7200}, at_5, record_s=4 * 3600)
    assert c.window_s == 7200 and c.step_s == 300  # the user's window: not shrunk
    c = make_config({"preset": "siso", "pooled_windows": 3}, at_5, record_s=4 * 3600)
    assert c.pooled_windows == 3 and c.window_significance == DetectorConfig.preset("siso").window_significance
    # the user's end of training stays (the config's training is not rewritten); the window
    # shrinks only when the rest of the record cannot hold one
    c = make_config("siso", at_5, record_s=3 * 3600, train_end_s=3600 * 1.5)
    assert c.train_duration_s == DetectorConfig.preset("siso").train_duration_s
    assert c.window_s == 1.5 * 3600
    c = make_config("siso", at_5, record_s=4 * 3600, train_end_s=3600)
    assert c.to_json() == make_config("siso", at_5).to_json()  # 3 h monitored: a 2 h window fits


def test_detect_on_a_short_record_runs_and_says_how_it_was_fitted():
    model, data = _record(5.0, 4.0)
    result = detect(model, data, config="siso")
    assert result.train_end_s == 7200
    assert (~result.windows["training"]).sum() >= 1
    note = [n for n in result.notes if n.startswith("record of 4 h")]
    assert len(note) == 1 and "training 2 h (at most 50% of the record)" in note[0]
    assert "window 1 h = 720 samples" in note[0] and "single windows" in note[0]
    # below 2.5 windows of MIN_WINDOW_SAMPLES (training 1.5, monitored 1): the one-line refusal
    model, data = _record(5.0, 2.0)
    with pytest.raises(ValueError, match=r"^data: the record spans 2 h; detection needs at least 2\.083 h at 5 s "
                                         r"sampling \(training 1\.25 h plus one 50 min window\); `compare` and `diagnose`"):
        detect(model, data, config="siso")


def test_cli_detect_without_train_end_trains_on_the_fitted_period(tmp_path):
    code, text = _cli_detect(tmp_path, 5.0, 4.0)
    assert code == 0
    assert text.startswith("trained on 0.00 h .. 2.00 h (2 h)") and "windows of 1 h every 2.5 min" in text
    assert "note: record of 4 h: training 2 h" in text
