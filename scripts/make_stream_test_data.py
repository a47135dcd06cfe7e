"""Writes the small committed test data of the streaming detector into a folder
(default tests/data/stream): a paper-scenario data set, the detector Python trains on it,
and the batch `mpmpp detect --json` results the C++ streaming path must reproduce.

    PYTHONPATH=python python scripts/make_stream_test_data.py [OUT_DIR]

Files: model.json, data.csv (paper SISO scenario, seed 0, inputs/outputs only, 6 significant
digits, two missing cells: one in the training period, one after the MPM onset, which the
windows do without, and 20 minutes of missing output at 12 h, more than the tenth of a window
a window may lose, so skipped windows are exercised), detector.json (`mpmpp detect --save-detector`), batch.json (the
`mpmpp detect --json` document), expected_alarms.csv and expected_scores.csv (batch alarms
from the saved detector reloaded and monitoring the whole data set, in the stream_csv
example's CSV layout).
tests/python/test_streaming_detector.py runs the same steps live in a temporary folder.
"""
from __future__ import annotations

import contextlib
import io
import json
import math
import os
import sys

TRAIN_END_S = 10800.0  # paper Table 1: 3 h of training


def write_dataset(out_dir: str) -> tuple[str, str]:
    """model.json and data.csv of the paper SISO scenario (seed 0) with two missing cells."""
    import mpmpp
    from mpmpp.evaluate import load_scenario, nominal_model

    scenario = load_scenario("paper_siso")
    model = nominal_model(scenario)
    data = mpmpp.simulate(scenario, seed=0)
    data = data[["time", *model.inputs, *model.outputs]].copy()
    ts = model.sample_time_s
    data.loc[int(100 / ts), model.inputs[0]] = math.nan  # in the first (training) window only
    data.loc[int(14.0 * 3600 / ts), model.outputs[0]] = math.nan  # while monitoring
    data.loc[int(12.0 * 3600 / ts):int(12.0 * 3600 / ts) + int(1200 / ts) - 1, model.outputs[0]] = math.nan
    model_path, data_path = os.path.join(out_dir, "model.json"), os.path.join(out_dir, "data.csv")
    mpmpp.save_model(model, model_path)
    data.to_csv(data_path, index=False, float_format="%.6g", na_rep="")
    return model_path, data_path


def batch_detect(model_path: str, data_path: str, out_dir: str) -> dict:
    """`mpmpp detect MODEL DATA --train-end 10800 --config paper_siso --json --save-detector detector.json`
    (the paper's Table 1 verbatim, so the data does not change when the default preset is retuned)."""
    from mpmpp import cli

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = cli.main(["detect", model_path, data_path, "--train-end", str(TRAIN_END_S), "--config", "paper_siso", "--json",
                         "--save-detector", os.path.join(out_dir, "detector.json")])
    if code != 0:
        raise SystemExit(f"mpmpp detect failed ({code})")
    return json.loads(out.getvalue())


def alarms_csv(result) -> str:
    """A DetectionResult's alarms in the detector_io alarms CSV (stream_csv --alarms-csv)."""
    from mpmpp import _core

    return _core.detection_alarms_csv(*result.core)


def scores_csv(result) -> str:
    """Every window of a DetectionResult in the detector_io scores CSV (stream_csv --scores-csv)."""
    from mpmpp import _core

    return _core.detection_scores_csv(*result.core)


def monitor_saved(out_dir: str, data_path: str):
    """The saved detector reloaded and run in batch over the whole data set."""
    import mpmpp

    detector = mpmpp.Detector.load(os.path.join(out_dir, "detector.json"))
    return detector.monitor(mpmpp.load_data(data_path, detector.model))


def main(out_dir: str) -> None:
    os.makedirs(out_dir, exist_ok=True)
    model_path, data_path = write_dataset(out_dir)
    batch = batch_detect(model_path, data_path, out_dir)
    with open(os.path.join(out_dir, "batch.json"), "w", encoding="utf-8") as f:
        json.dump({k: batch[k] for k in ("train_end_s", "channels", "alarms", "threshold", "skipped_windows")}, f,
                  indent=1)
    result = monitor_saved(out_dir, data_path)
    if [{k: v for k, v in a.items() if k != "channel"} for a in result.alarms] != batch["alarms"]:
        raise SystemExit("the reloaded detector's alarms differ from mpmpp detect's")
    for name, text in (("expected_alarms.csv", alarms_csv(result)), ("expected_scores.csv", scores_csv(result))):
        with open(os.path.join(out_dir, name), "w", encoding="utf-8") as f:
            f.write(text)
    print(f"{out_dir}: {len(batch['windows'])} windows kept, {len(batch['skipped_windows'])} skipped, "
          f"alarms {[(a['kind'], a['start_s']) for a in batch['alarms']]}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "tests", "data", "stream"))
