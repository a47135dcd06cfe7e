"""The example cases shipped in examples/ (written by scripts/make_examples.py): each a model
file, a data file, and answer.json naming the effect hidden in the data. The tests take their
expected answers from answer.json, never from literals."""
from __future__ import annotations

import json
from pathlib import Path

import mpmpp

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"
GAIN_CHANGE = "siso_gain_change"
MISSING_COUPLING = "mimo_missing_coupling"
NOISE_CHANGE = "mimo_noise_change"
CASES = (GAIN_CHANGE, MISSING_COUPLING, NOISE_CHANGE)


def model_path(case: str) -> Path:
    return EXAMPLES / case / "model.json"


def data_path(case: str) -> Path:
    return EXAMPLES / case / "data.csv"


def hidden_effect(case: str) -> dict:
    """The (single) finding answer.json lists for ``case``."""
    [finding] = json.loads((EXAMPLES / case / "answer.json").read_text())["findings"]
    return finding


def load_case(case: str):
    """(model, data, hidden effect) of an example case."""
    model = mpmpp.load_model(model_path(case))
    return model, mpmpp.load_data(data_path(case), model), hidden_effect(case)
