"""The command line frame: --version, --help everywhere (and cheap), check's output."""
import json
import math
import subprocess
import sys

import numpy as np
import pandas as pd
import pathlib
import pytest

import mpmpp
from mpmpp import cli
from example_cases import GAIN_CHANGE, data_path, model_path


def test_version(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"mpmpp {mpmpp.__version__}"


@pytest.mark.parametrize("command", [[]] + [[name] for name in cli.COMMANDS])
def test_help_everywhere(command, capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(command + ["--help"])
    assert exit_.value.code == 0
    assert "usage: mpmpp" in capsys.readouterr().out


@pytest.mark.parametrize("argv, prog", [(["simulate", "s.json", "--force"], "mpmpp simulate"),
                                        (["--force"], "mpmpp")])
def test_an_unknown_option_is_named_by_its_command(argv, prog, capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(argv)
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"usage: {prog}") and f"{prog}: error: unrecognized arguments: --force" in err


def test_check_json_summary(capsys):
    model, data = model_path(GAIN_CHANGE), data_path(GAIN_CHANGE)
    assert cli.main(["check", str(model), str(data), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    m, df = mpmpp.load_model(model), mpmpp.load_data(data, mpmpp.load_model(model))
    [channel] = report["model"]["channels"]
    assert (channel["output"], channel["input"]) == m.channels()[0]
    assert channel["dc_gain"] == m.process(*m.channels()[0]).dc_gain()
    assert report["data"]["samples"] == len(df)
    assert report["data"]["duration_s"] == len(df) * m.sample_time_s
    assert report["data"]["missing"] == {c: 0 for c in df.columns if c != "time"}
    assert report["data"]["frozen"] == {}


def test_check_counts_missing_and_integrating_channel(tmp_path, capsys):
    integrator = mpmpp.TransferFunction([0.1], [1.0, -1.0], 3)  # 0.1 e^(-2 s) / s at Ts = 1 s
    lagged = mpmpp.TransferFunction([0.1], [1.0, -2.0, 1.0])  # a double integrator: no reading
    model = mpmpp.Model("int", 1.0, ["u", "v"], ["y"], {"y": {"u": integrator, "v": lagged}})
    mpmpp.save_model(model, tmp_path / "m.json")
    (tmp_path / "d.csv").write_text("time,u,v,y,y_sp,x\n0,1,0,,0,1\n1,,0,2,0,\n2,1,0,2,0,3\n")
    assert cli.main(["check", str(tmp_path / "m.json"), str(tmp_path / "d.csv")]) == 0
    out = capsys.readouterr().out
    assert "y <- u: integrating, rate gain 0.1 per s, dead time 2 s" in out
    assert "y <- v: integrating (infinite dc gain)" in out
    assert "missing values: u 1, y 1, x 1 (2 rows affected" in out
    assert "setpoints: y_sp" in out and "candidates for diagnose): x" in out


def test_check_says_which_lost_output_samples_the_analyses_interpolate(tmp_path, capsys):
    """Two lone lost PV samples in 300 rows are interpolated by compare, diagnose and identify
    (signals.bridge_lost_outputs); a lost OP sample and a PV lost beside it end a segment."""
    model = mpmpp.Model("m", 1.0, ["OP"], ["PV"], {"PV": {"OP": mpmpp.TransferFunction([0.5], [1.0, -0.5], 1)}})
    mpmpp.save_model(model, tmp_path / "m.json")
    t = np.arange(300)
    op, pv = np.sin(t / 7.0), np.cos(t / 5.0)
    pv[[40, 150, 201]] = np.nan
    op[200] = np.nan
    pd.DataFrame({"time": t, "OP": op, "PV": pv}).to_csv(tmp_path / "d.csv", index=False)
    assert cli.main(["check", str(tmp_path / "m.json"), str(tmp_path / "d.csv"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["data"]["interpolated"] == {"PV": 2}
    assert cli.main(["check", str(tmp_path / "m.json"), str(tmp_path / "d.csv")]) == 0
    out = capsys.readouterr().out
    assert "missing values: OP 1, PV 3 (4 rows affected)" in out
    assert "interpolated by compare, diagnose and identify" in out and "): PV 2;" in out


def test_python_dash_m_runs_the_command_line(tmp_path):
    model = tmp_path / "m.json"
    mpmpp.save_model(mpmpp.Model("m", 1.0, ["u"], ["y"], {"y": {"u": mpmpp.TransferFunction([0.5], [1.0, -0.5], 1)}}),
                     model)
    env = {"PYTHONPATH": str(pathlib.Path(mpmpp.__file__).parents[1])}
    ok = subprocess.run([sys.executable, "-m", "mpmpp", "check", str(model)], capture_output=True, text=True, env=env)
    assert ok.returncode == 0 and "y <- u" in ok.stdout
    bad = subprocess.run([sys.executable, "-m", "mpmpp", "check", str(tmp_path / "none.json")], capture_output=True,
                         text=True, env=env)
    assert bad.returncode == 2 and bad.stderr.startswith("mpmpp check: error:")


def test_help_loads_no_engine_and_no_heavy_library():
    # What `mpmpp --help` costs: only argparse and the command table. A fresh interpreter,
    # since this test process has long imported everything.
    code = ("import sys; from mpmpp import cli; cli.build_parser(['--help']); cli.build_parser(['check', '-h']); "
            "print(sorted(m for m in ('numpy', 'pandas', 'matplotlib', 'mpmpp._core') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(pathlib.Path(mpmpp.__file__).parents[1])}).stdout
    assert out.strip() == "['numpy']"  # check's own module needs NumPy; --help alone needs nothing


def test_commands_run_blas_single_threaded_unless_the_user_says_otherwise(tmp_path):
    model = tmp_path / "m.json"
    mpmpp.save_model(mpmpp.Model("m", 1.0, ["u"], ["y"], {"y": {"u": mpmpp.TransferFunction([0.5], [1.0, -0.5], 1)}}),
                     model)
    code = (f"import os; from mpmpp import cli; cli.main(['check', {str(model)!r}]); "
            "import numpy; print('threads', os.environ['OPENBLAS_NUM_THREADS'])")
    env = {"PYTHONPATH": str(pathlib.Path(mpmpp.__file__).parents[1])}
    run = lambda extra: subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,  # noqa: E731
                                       check=True, env={**env, **extra}).stdout
    assert "threads 1" in run({})
    assert "threads 4" in run({"OPENBLAS_NUM_THREADS": "4"})


def test_lazy_package_names_are_the_functions():
    import mpmpp.simulate  # noqa: F401  (binds the submodule on the package, as any import does)
    import mpmpp.detect  # noqa: F401
    assert callable(mpmpp.simulate) and mpmpp.simulate.__name__ == "simulate"
    assert mpmpp.detect.__name__ == "detect" and mpmpp.scenarios.paper_siso()["name"]
    with pytest.raises(AttributeError, match="no_such_name"):
        _ = mpmpp.no_such_name


@pytest.mark.parametrize("gain, tau, dead", [(0.9, 68.9, 65.0), (-2.5, 300.0, 72.5), (1.3, 0.0, 20.0),
                                             (0.4, 12.0, 0.0)])
def test_check_shows_gain_time_constant_dead_time(gain, tau, dead, tmp_path, capsys):
    # Analytic: check reads back exactly what the zero-order-hold discretisation was given.
    g = mpmpp.TransferFunction.from_foptd(gain=gain, time_constant_s=tau, dead_time_s=dead, sample_time_s=5.0)
    mpmpp.save_model(mpmpp.Model("m", 5.0, ["u"], ["y"], {"y": {"u": g}}), tmp_path / "m.json")
    assert cli.main(["check", str(tmp_path / "m.json"), "--json"]) == 0
    f = json.loads(capsys.readouterr().out)["model"]["channels"][0]["foptd"]
    assert f["exact"]
    assert f["gain"] == pytest.approx(gain, rel=1e-9)
    assert f["time_constant_s"] == pytest.approx(tau, rel=1e-9, abs=1e-9)
    assert f["dead_time_s"] == pytest.approx(dead, rel=1e-9, abs=1e-9)
    assert cli.main(["check", str(tmp_path / "m.json"), "--detail"]) == 0
    out = capsys.readouterr().out
    assert f"gain {gain:.4g}, time constant {tau:.4g} s, dead time {dead:.4g} s" in out
    assert f"in q^-1: {g}" in out


def test_check_reads_a_higher_order_channel_from_its_step_response(tmp_path, capsys):
    # Two lags (60 s, 20 s) behind 8 samples of delay. Reference: SciPy's step response, the
    # dead time where it leaves zero less the hold's sample, the time constant where it
    # crosses 63% (interpolated) less the dead time.
    from scipy import signal

    ts, delay, gain = 5.0, 8, 1.5
    a1, a2 = math.exp(-ts / 60.0), math.exp(-ts / 20.0)
    num, den = [(1 - a1) * (1 - a2) * gain], [1.0, -(a1 + a2), a1 * a2]
    g = mpmpp.TransferFunction(num, den, delay)
    mpmpp.save_model(mpmpp.Model("m", ts, ["u"], ["y"], {"y": {"u": g}}), tmp_path / "m.json")
    assert cli.main(["check", str(tmp_path / "m.json"), "--json"]) == 0
    f = json.loads(capsys.readouterr().out)["model"]["channels"][0]["foptd"]
    step = signal.lfilter(np.r_[np.zeros(delay), num], den, np.ones(400))
    dead = (np.flatnonzero(step)[0] - 1) * ts
    t63 = np.interp(1 - math.exp(-1), step / gain, np.arange(400) * ts)  # monotone response
    assert not f["exact"] and f["gain"] == pytest.approx(gain, rel=1e-9)
    assert f["dead_time_s"] == pytest.approx(dead, abs=1e-9)
    assert f["time_constant_s"] == pytest.approx(t63 - dead, rel=1e-9)
    assert 60.0 < f["time_constant_s"] < 60.0 + 20.0 + ts  # the slow lag, plus about the fast one


def test_paper_scenarios_have_one_spelling_and_accept_the_old_one():
    from mpmpp.evaluate import load_scenario

    assert load_scenario("paper_siso") == load_scenario("paper-siso") == mpmpp.scenarios.paper_siso()
    assert load_scenario("paper_mimo") == load_scenario("paper-mimo") == mpmpp.scenarios.paper_mimo()
