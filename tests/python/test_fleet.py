"""`mpmpp monitor FLEET`: a fleet of 100 small loops gives one table, the same on local
processes and on a Dask LocalCluster, and each row is what monitoring that loop alone gives."""
import json
import os
import shutil

import pandas as pd
import pytest

from mpmpp.fleet import format_fleet_table, load_fleet, monitor_fleet
from mpmpp.monitor import monitor
from cli_run import run_cli

HERE = os.path.dirname(os.path.abspath(__file__))
STREAM = os.path.join(HERE, "..", "data", "stream")
DETECTOR, DATA = os.path.join(STREAM, "detector.json"), os.path.join(STREAM, "data.csv")
N_LOOPS = 100
HOURS = 6  # 3 h of the detector's training period, then 3 h monitored


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """100 loops: 6 h stretches of the committed record starting at different times (some
    hold its noise or gain change after their training period, some do not), plus a manifest."""
    folder = tmp_path_factory.mktemp("fleet")
    df = pd.read_csv(DATA)
    rows = int(HOURS * 3600 / 5)
    offsets = [round(k * (len(df) - rows) / (N_LOOPS - 1)) for k in range(N_LOOPS)]
    lines = ["loop,detector,data"]
    for k, off in enumerate(offsets):
        name = f"loop{k:03d}"
        df.iloc[off:off + rows].to_csv(folder / f"{name}.csv", index=False, float_format="%.17g", na_rep="")
        lines.append(f"{name},{DETECTOR},{name}.csv")
    (folder / "fleet.csv").write_text("\n".join(lines) + "\n")
    return folder


def test_fleet_runs_locally_and_on_dask_with_identical_tables(fleet):
    distributed = pytest.importorskip("distributed")
    local = monitor_fleet(fleet / "fleet.csv", workers=2)
    assert len(local["loops"]) == N_LOOPS and "2 local processes" == local["where"]
    counts = local["counts"]
    assert counts["error"] == 0 and counts["ALARM"] > 0 and counts["ok"] > 0, counts
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        remote = monitor_fleet(fleet / "fleet.csv", scheduler=client)
    assert "Dask" in remote["where"]
    assert remote["loops"] == local["loops"]
    assert format_fleet_table(remote) == format_fleet_table(local)
    # Every row is the loop monitored on its own.
    by_name = {r["loop"]: r for r in local["loops"]}
    for name in ("loop000", "loop042", "loop099"):
        alone = monitor(DETECTOR, str(fleet / f"{name}.csv"))
        assert by_name[name]["alarms"] == len(alone.alarms)
        assert by_name[name]["status"] == ("ALARM" if any(alone.active) else "ok")


def test_fleet_folder_from_the_cli_with_checkpoints_and_a_broken_loop(fleet, tmp_path):
    folder = tmp_path / "plant"
    for k, name in enumerate(["FIC101", "TIC205", "broken"]):
        (folder / name).mkdir(parents=True)
        shutil.copy(DETECTOR, folder / name / "detector.json")
        src = fleet / f"loop{30 * k:03d}.csv"
        if name == "broken":
            (folder / name / "data.csv").write_text("time,stock_flow\n0,1\n5,2\n")
        else:
            shutil.copy(src, folder / name / "data.csv")
    ckpts, table = tmp_path / "ckpt", tmp_path / "table.csv"
    code, out, err = run_cli("monitor", folder, "--workers", 1, "--checkpoints", ckpts, "--csv", table)
    assert code == 0, err
    assert "3 loops:" in out and "with errors" in out
    rows = list(pd.read_csv(table, keep_default_na=False).itertuples())
    assert [r.loop for r in rows][0] == "broken" and rows[0].status == "error"
    assert "dry_weight" in rows[0].message  # names the missing column
    assert sorted(os.listdir(ckpts)) == ["FIC101.checkpoint.json", "TIC205.checkpoint.json"]
    # Second run on the same data: everything already monitored; the table is not replaced silently.
    code, _, err = run_cli("monitor", folder, "--workers", 1, "--checkpoints", ckpts, "--csv", table)
    assert code == 2 and "--force" in err
    code, out, err = run_cli("monitor", folder, "--workers", 1, "--checkpoints", ckpts, "--json", "--csv", table,
                             "--force")
    assert code == 0, err
    again = {r["loop"]: r for r in json.loads(out)["loops"]}
    assert again["FIC101"]["samples"] == 0 and again["TIC205"]["windows"] == 0


def test_bad_fleets_are_one_line_and_exit_2(tmp_path):
    bad = tmp_path / "m.csv"
    bad.write_text("loop,detector,data\nA,d.json,\n")
    empty = tmp_path / "empty"
    empty.mkdir()
    twice = tmp_path / "twice.json"
    twice.write_text(json.dumps({"loops": [{"loop": "A", "detector": "d", "data": "x"},
                                           {"loop": "A", "detector": "d", "data": "y"}]}))
    for spec, named in [(bad, "field 'data'"), (empty, "no loop folders"), (twice, "listed twice"),
                        (tmp_path / "nothing", "no such fleet")]:
        code, _, err = run_cli("monitor", spec)
        assert code == 2 and named in err and len(err.strip().splitlines()) == 1, err
    with pytest.raises(ValueError, match="listed twice"):
        load_fleet(twice)
