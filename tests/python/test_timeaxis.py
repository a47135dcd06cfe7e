"""Times as the outputs show them: durations in words, moments in the data's own clock."""
import numpy as np
import pandas as pd
import pytest

from mpmpp.timeaxis import absolute_seconds, format_duration, format_moment, origin_of, plot_axis


@pytest.mark.parametrize("seconds, text", [
    (45, "45 s"), (7.5, "7.5 s"), (600, "10 min"), (34500, "9 h 35 min"), (3600, "1 h"),
    (2 * 86400 + 3 * 3600, "2 d 3 h"), (-300, "-5 min"), (59.6 * 60, "1 h")])
def test_durations_read_as_words(seconds, text):
    assert format_duration(seconds) == text


def test_moments_in_the_data_s_own_clock():
    df = pd.DataFrame({"time": [0.0, 5.0]})
    df.attrs["time_origin"] = "2024-03-31T01:59:55+01:00"
    origin = origin_of(df)
    assert format_moment(3605.0, origin) == "2024-03-31 02:00:00 UTC"
    # Epoch seconds against pandas' own conversion.
    expected = pd.Timestamp("2024-03-31T01:59:55+01:00").timestamp() + 5.0
    assert absolute_seconds([5.0], origin)[0] == pytest.approx(expected, abs=1e-6)
    x, label, convert = plot_axis(df["time"], origin)
    assert label == "time (UTC)" and x.dtype.kind == "M" and str(x[1]) == "2024-03-31T01:00:00.000"
    assert origin_of(pd.DataFrame({"time": [0.0]})) is None
    with pytest.raises(ValueError, match="time origin"):
        origin_of("not a time")


def test_plain_seconds_count_from_the_first_sample():
    assert format_moment(34500.0, None, 0.0) == "t = 34500 s (9 h 35 min after the first sample)"
    x, label, convert = plot_axis(np.array([3600.0, 3600.0 + 6 * 3600]))
    assert label == "time since the first sample (h)" and list(x) == [0.0, 6.0]
    x, label, _ = plot_axis(np.array([0.0, 1800.0]))
    assert label == "time (min)" and list(x) == [0.0, 30.0]
