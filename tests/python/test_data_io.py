"""Data file: read against pandas, missing values, timestamps, write/read round trip."""
import csv
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings, strategies as st

import mpmpp

from example_cases import CASES, data_path, model_path


def small_model(ts=5.0):
    return mpmpp.Model("m", ts, ["u"], ["y"], {"y": {"u": mpmpp.TransferFunction([0.5], [1.0, -0.5], 1)}})


@pytest.mark.parametrize("case", CASES)
def test_case_data_matches_pandas(case):
    model = mpmpp.load_model(model_path(case))
    df = mpmpp.load_data(data_path(case), model)
    # Reference: the csv module and Python's correctly rounded float().
    with open(data_path(case), newline="") as f:
        header, *rows = list(csv.reader(f))
    assert list(df.columns) == header
    np.testing.assert_array_equal(df.to_numpy(), np.array([[float(x) for x in r] for r in rows]))
    assert df.attrs["missing"] == {c: 0 for c in header if c != "time"}
    assert df.attrs["time_origin"] is None


def test_missing_values_are_nan_and_counted(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("time,u,y,extra\n0,1,,3\n5,NaN,2,nan\n10, 1.5 ,2.5,\n15,2,3,4\n")
    df = mpmpp.load_data(p, small_model())
    assert df.attrs["missing"] == {"u": 1, "y": 1, "extra": 2}
    assert np.isnan(df["u"][1]) and np.isnan(df["y"][0]) and df["u"][2] == 1.5
    np.testing.assert_array_equal(df["time"], [0, 5, 10, 15])


def test_iso_timestamps_become_seconds_since_the_first(tmp_path):
    stamps = pd.date_range("2024-02-28T23:59:50", periods=6, freq="5s")  # crosses a leap day
    p = tmp_path / "d.csv"
    lines = ["time,u,y"] + [f"{t.isoformat()},{k},{2 * k}" for k, t in enumerate(stamps)]
    p.write_text("\n".join(lines) + "\n")
    df = mpmpp.load_data(p, small_model())
    np.testing.assert_array_equal(df["time"], (stamps - stamps[0]).total_seconds())
    assert df.attrs["time_origin"] == stamps[0].isoformat()


def test_iso_timestamps_with_offsets_are_compared_in_utc(tmp_path):
    # The same instants written in two time zones: 5 s apart in UTC.
    p = tmp_path / "d.csv"
    p.write_text("time,u,y\n2024-06-01T10:00:00+02:00,1,1\n2024-06-01 08:00:05Z,1,1\n"
                 "2024-06-01T03:00:10.000-05:00,1,1\n")
    df = mpmpp.load_data(p, small_model())
    np.testing.assert_array_equal(df["time"], [0.0, 5.0, 10.0])


def test_quoted_header_and_fields(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text('"time","u","y","flow, raw"\r\n0,"1.5",2,3\r\n5,1,2,3\r\n')
    df = mpmpp.load_data(p, small_model())
    assert list(df.columns) == ["time", "u", "y", "flow, raw"]
    assert df["u"][0] == 1.5


def test_load_without_model_skips_model_checks(tmp_path):
    p = tmp_path / "d.csv"
    p.write_text("time,a\n0,1\n1,2\n3,3\n")
    df = mpmpp.load_data(p)
    np.testing.assert_array_equal(df["time"], [0, 1, 3])


# every number a data file may hold: finite and below 1e100 in magnitude (data_io.hpp)
finite = st.floats(min_value=-9.99e99, max_value=9.99e99, allow_nan=False, width=64)


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 30),
    ts=st.floats(1e-3, 1e4),
    t0=st.floats(-1e6, 1e6),
    data=st.data(),
)
def test_save_load_round_trip_is_exact(tmp_path_factory, n, ts, t0, data):
    # Time as integers times Ts so the spacing is exact after the decimal round trip.
    time = t0 + ts * np.arange(n)
    cols = {name: np.array(data.draw(st.lists(st.one_of(finite, st.just(math.nan)), min_size=n, max_size=n)))
            for name in ["u", "y", "x,with comma"]}
    df = pd.DataFrame({"time": time, **cols})
    path = tmp_path_factory.mktemp("rt") / "d.csv"
    mpmpp.save_data(path, df)
    back = mpmpp.load_data(path)
    assert list(back.columns) == list(df.columns)
    np.testing.assert_array_equal(back.to_numpy(), df.to_numpy())
    assert back.attrs["missing"] == {c: int(np.isnan(v).sum()) for c, v in cols.items()}


def test_save_data_rejects_bad_frames(tmp_path):
    with pytest.raises(ValueError, match="no 'time' column"):
        mpmpp.save_data(tmp_path / "d.csv", pd.DataFrame({"u": [1.0]}))
    with pytest.raises(ValueError, match="strictly increasing"):
        mpmpp.save_data(tmp_path / "d.csv", pd.DataFrame({"time": [0.0, 0.0], "u": [1.0, 2.0]}))
    with pytest.raises(ValueError, match="numeric"):
        mpmpp.save_data(tmp_path / "d.csv", pd.DataFrame({"time": [0.0], "u": ["a"]}))
    with pytest.raises(ValueError, match="column u: value 1e\\+100 at sample 1 is too large to compute with"):
        mpmpp.save_data(tmp_path / "d.csv", pd.DataFrame({"time": [0.0, 1.0], "u": [1.0, 1e100]}))
    assert not (tmp_path / "d.csv").exists()


@settings(max_examples=200, deadline=None)
@given(text=st.text(alphabet=st.sampled_from(list('time,uy0123456789.-+e"NaZT:\r\n ')), max_size=80))
def test_arbitrary_csv_text_gives_a_one_line_error_or_a_table(text):
    try:
        table = mpmpp._core.parse_csv(text, "d.csv")
    except ValueError as exc:
        assert str(exc).startswith("d.csv: ") and "\n" not in str(exc)
    else:
        assert table.values.shape == (table.num_samples, len(table.columns))
        assert np.all(np.diff(table.time_s) > 0)
