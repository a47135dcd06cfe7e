"""Monte Carlo evaluation: scoring rules on hand-made runs, and the same numbers from local
processes and from a Dask LocalCluster."""
import numpy as np
import pytest

import mpmpp
from mpmpp.evaluate import evaluate, format_table, summarise, truth_onsets

H = 3600.0


def short_siso():
    """The paper's SISO loop compressed: noise change at 5 h, gain doubled at 7.5 h, 10 h."""
    s = mpmpp.scenarios.paper_siso()
    s["duration_s"] = 10 * H
    s["events"][0]["time_s"] = 5 * H
    s["events"][1]["time_s"] = 7.5 * H
    return s


def test_truth_onsets_of_paper_scenarios():
    on = truth_onsets(mpmpp.scenarios.paper_mimo())
    assert on["process"][("reel_moisture", "stock_flow")] == 1000 * 60
    assert on["process"][("press_dry_weight", "stock_flow")] == 1250 * 60
    assert on["process"][("press_moisture", "steam_4")] is None
    assert on["noise"] == {"press_dry_weight": None, "press_moisture": 575 * 60, "reel_moisture": None}


def test_summarise_counts_detections_false_alarms_and_delays():
    onsets = {"process": {("y", "u"): 10 * H}, "noise": {"y": 5 * H}}
    G, N = "G[y <- u]", "H[y]"
    runs = [  # detected 1 h late; noise detected 2 h late
        {"alarms": {G: [11 * H], N: [7 * H]}, "baselines": {"variance": {"y": [6 * H]}, "residual": {"y": []}}},
        # false MPM alarm during the noise change, then detected 3 h late
        {"alarms": {G: [6 * H, 13 * H], N: [6 * H]}, "baselines": {"variance": {"y": []}, "residual": {"y": [12 * H]}}},
        # missed; false noise alarm before the noise change
        {"alarms": {G: [], N: [4 * H]}, "baselines": {"variance": {"y": []}, "residual": {"y": []}}},
    ]
    for r in runs:
        r["seconds"] = {"total": 1.0}
        r["skipped_windows"] = 0
    s = summarise(runs, onsets, None)
    svm_g = next(r for r in s["rows"] if r["method"] == "svm" and r["kind"] == "MPM")
    assert svm_g["detection_rate"] == pytest.approx(2 / 3)
    assert svm_g["false_alarm_rate"] == pytest.approx(1 / 3)
    assert svm_g["delay_median_s"] == pytest.approx(2 * H)
    assert svm_g["delay_p90_s"] == pytest.approx(np.percentile([H, 3 * H], 90))
    svm_h = next(r for r in s["rows"] if r["method"] == "svm" and r["kind"] == "noise")
    assert svm_h["detection_rate"] == pytest.approx(2 / 3) and svm_h["false_alarm_rate"] == pytest.approx(1 / 3)
    assert s["svm"]["noise_change_alarm_rate"] == pytest.approx(1 / 3)
    assert s["baselines"]["variance"]["noise_change_alarm_rate"] == pytest.approx(1 / 3)
    assert s["baselines"]["residual"]["noise_change_alarm_rate"] == 0.0
    res = next(r for r in s["rows"] if r["method"] == "residual")
    assert res["detection_rate"] == pytest.approx(1 / 3) and res["delay_median_s"] == pytest.approx(2 * H)


def test_dask_local_cluster_gives_the_same_numbers_as_local_processes():
    distributed = pytest.importorskip("dask.distributed")
    scen = short_siso()
    cfg = {"preset": "paper_siso", "resampled_models": 100, "outlier_fraction": 0.05}
    local = evaluate(scen, [0, 1], config=cfg, workers=2, progress=False)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = evaluate(scen, [0, 1], config=cfg, scheduler=client, progress=False)
    assert remote["rows"] == local["rows"]
    assert remote["seeds"] == 2 and "Dask" in remote["where"]
    table = format_table(remote)
    assert "| svm | G[dry_weight <- stock_flow] | MPM |" in table and "residual" in table


def test_cli_evaluate_bad_arguments_exit_2(capsys):
    from mpmpp.cli import main

    assert main(["evaluate", "paper_siso", "--seeds", "0"]) == 2
    assert "--seeds" in capsys.readouterr().err
    assert main(["evaluate", "/nonexistent/scenario.json", "--seeds", "1"]) == 2
    assert "cannot read the scenario" in capsys.readouterr().err
