"""The committed example cases are what scripts/make_examples.py writes: the project's own
simulator made them, and the answers the tests read are the scenario's effects."""
import importlib.util
import json

import numpy as np
import pandas as pd
import pytest

from example_cases import CASES, EXAMPLES, REPO

spec = importlib.util.spec_from_file_location("make_examples", REPO / "scripts" / "make_examples.py")
make_examples = importlib.util.module_from_spec(spec)
spec.loader.exec_module(make_examples)


def test_every_example_is_listed_and_small():
    assert sorted(make_examples.EXAMPLES) == sorted(CASES)
    assert sorted(p.name for p in EXAMPLES.iterdir() if p.is_dir()) == sorted(CASES)
    for case in CASES:
        assert (EXAMPLES / case / "data.csv").stat().st_size < 500_000


@pytest.mark.parametrize("case", CASES)
def test_the_script_writes_the_committed_files(case, tmp_path):
    folder = make_examples.write_example(case, tmp_path)
    committed = EXAMPLES / case
    for name in ("model.json", "answer.json", "scenario.json"):
        assert (folder / name).read_text() == (committed / name).read_text(), name
    new, old = pd.read_csv(folder / "data.csv"), pd.read_csv(committed / "data.csv")
    assert list(new.columns) == list(old.columns) and len(new) == len(old)
    # 6 significant digits: a last-digit rounding flip across platforms is the most allowed.
    np.testing.assert_allclose(new.to_numpy(), old.to_numpy(), rtol=2e-6, atol=0)


def test_answers_follow_from_the_scenarios():
    gain = make_examples.answer({"name": "s", "sample_time_s": 5.0, "process": {"y": {"u": {}}},
                                 "events": [{"time_s": 100.0, "type": "gain", "output": "y", "input": "u",
                                             "factor": 1.5}]})
    assert gain == {"findings": [{"effect": "gain", "output": "y", "input": "u", "onset_s": 100.0, "ratio": 1.5}]}
    coupling = json.loads((EXAMPLES / "mimo_missing_coupling" / "answer.json").read_text())["findings"][0]
    truth = json.loads((EXAMPLES / "mimo_missing_coupling" / "scenario.json").read_text())["truth"]["process"]
    g = truth[coupling["output"]][coupling["input"]]
    assert coupling["gain"] == pytest.approx(sum(g["num"]) / sum(g["den"]), rel=1e-12)
    with pytest.raises(ValueError, match="no answer written for a 'drift' event"):
        make_examples.answer({"name": "s", "process": {}, "events": [{"time_s": 0.0, "type": "drift", "output": "y"}]})
