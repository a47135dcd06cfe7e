"""A value too large to compute with (magnitude 1e100 or more: its squares summed over a record
overflow) or an infinity in a data frame. The file reader names the cell; arrays and data
frames get the same rule (held_values.require_computable). Before, the fits met the infinities
far from the cause: "SVD did not converge" (diagnose, identify), a ZeroDivisionError traceback
(stiction), "0 usable windows" (detect), and an infinity in a frame passed for a missing value."""
import re

import numpy as np
import pytest

import mpmpp
from mpmpp import cli
from mpmpp._core import LARGEST_VALUE
from mpmpp.diagnose import diagnose
from mpmpp.held_values import require_computable
from mpmpp.identify import model_from_data
from mpmpp.stiction import analyse_loop

import closed_loop_case as loop


@pytest.mark.parametrize("command", ["check", "compare", "detect", "diagnose", "identify", "stiction"])
def test_every_command_names_the_cell_in_one_line(command, tmp_path, capsys):
    data = loop.simulate(n=3000, seed=1)
    data["y"] = data["y"].astype(object)
    data.loc[40, "y"] = "-2.5e300"
    data.to_csv(tmp_path / "d.csv", index=False)
    mpmpp.save_model(loop.model(), tmp_path / "m.json")
    pair = [str(tmp_path / "m.json"), str(tmp_path / "d.csv")]
    args = {"identify": ["identify", str(tmp_path / "d.csv"), "--inputs", "u", "--outputs", "y",
                         "-o", str(tmp_path / "new.json")],
            "stiction": ["stiction", str(tmp_path / "d.csv"), "--op", "u", "--pv", "y"]}.get(command, [command, *pair])
    assert cli.main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert f'{tmp_path / "d.csv"}: row 42, column y: "-2.5e300" is too large to compute with' in err[0]
    assert not (tmp_path / "new.json").exists()


@pytest.mark.parametrize("value", [np.inf, -3e120])
def test_frames_and_arrays_get_the_same_rule(value):
    data = loop.simulate(n=3000, seed=1)
    data.loc[100, "u"] = value
    expected = f"column 'u' holds {value:.4g} at t={data.time[100]:g} s"
    for analysis in (lambda: diagnose(loop.model(), data), lambda: mpmpp.compare(loop.model(), data),
                     lambda: mpmpp.detect(loop.model(), data),
                     lambda: model_from_data(data, ["u"], ["y"])):
        with pytest.raises(ValueError, match=re.escape(expected)):
            analysis()


def test_the_valve_fit_names_op_or_pv():
    data = loop.simulate(n=751, seed=1)
    op = data.u.to_numpy(copy=True)
    op[100] = -3e120
    with pytest.raises(ValueError, match="column 'OP' holds -3e\\+120 at row 100"):
        analyse_loop(op, data.y.to_numpy())


def test_the_bound_is_the_readers():
    assert LARGEST_VALUE == 1e100
    require_computable(["u"], np.array([[9.9e99], [-9.9e99], [np.nan]]))   # allowed, missing allowed
    with pytest.raises(ValueError, match="column 'u' holds 1e\\+100 at row 1"):
        require_computable(["u"], np.array([[0.0], [1e100]]))


def test_a_model_built_in_python_with_a_channel_beyond_the_bound_is_named():
    # a model file's numbers are bounded on reading; one built in Python meets the same bound
    # where its channel is simulated (signals.require_simulable_channels)
    data = loop.simulate(n=3000, seed=1)
    big = mpmpp.Model("m", loop.TS, ["u"], ["y"], {"y": {"u": mpmpp.TransferFunction([3e99], [1.0, -0.9], 1)}})
    for analysis in (diagnose, mpmpp.compare):
        with pytest.raises(ValueError, match=r"process\.y\.u: its step response reaches magnitude 1e\+100 or more"):
            analysis(big, data)
