"""A data frame given to the analyses is checked as a file is (timeaxis.seconds_of,
signals.extract, detect): its time column present, finite, in order and each time once; rows to
train on; a column of text left out of the candidate columns."""
import re

import numpy as np
import pandas as pd
import pytest

import mpmpp
from mpmpp.diagnose import diagnose
from mpmpp.identify import model_from_data

import closed_loop_case as loop


@pytest.mark.parametrize("edit, message", [
    (lambda d: d.iloc[::-1].reset_index(drop=True), "column 'time' row 1: 14990 s is not after row 0's 14995 s"),
    (lambda d: pd.concat([d.iloc[:10], d.iloc[9:]]).reset_index(drop=True),
     "column 'time' row 10: 45 s is not after row 9's 45 s"),
    (lambda d: d.set_index("time"), "'time'"),   # each analysis names the missing column its own way
    (lambda d: d.assign(time=np.r_[np.nan, d.time.to_numpy()[1:]]), "column 'time' row 0: not a finite number"),
])
def test_a_frame_s_time_column_is_checked_as_a_file_s(edit, message):
    # rows out of order or repeated were analysed as if in order by diagnose and compare; a
    # frame without a time column was a KeyError traceback in diagnose
    data = edit(loop.simulate(n=3000, seed=1))
    for analysis in (lambda: diagnose(loop.model(), data), lambda: mpmpp.compare(loop.model(), data),
                     lambda: mpmpp.detect(loop.model(), data), lambda: model_from_data(data, ["u"], ["y"])):
        with pytest.raises(ValueError, match=re.escape(message)):
            analysis()


def test_an_empty_frame_and_a_text_column_in_a_frame():
    data = loop.simulate(n=3000, seed=1)
    with pytest.raises(ValueError, match="data: no rows to train on"):   # was an IndexError
        mpmpp.detect(loop.model(), data.iloc[:0])
    # a column of tag names is left out of the candidates, as the file reader leaves it out
    # (diagnose and compare stopped with NumPy's "could not convert string to float")
    tagged = data.assign(tag="FIC101")
    assert [f.effect for f in diagnose(loop.model(), tagged).findings] == [
        f.effect for f in diagnose(loop.model(), data).findings]
    assert mpmpp.compare(loop.model(), tagged).to_dict() == mpmpp.compare(loop.model(), data).to_dict()
