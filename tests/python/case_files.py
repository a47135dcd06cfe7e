"""Throwaway reader of the shared example cases for the tests, until the foundation's
``mpmpp.load_model`` / ``mpmpp.load_data`` are available (then those are used)."""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd

import mpmpp

SHARED = Path(__file__).resolve().parents[2] / ".." / "shared"
CASES = (SHARED / "cases").resolve()
if not CASES.exists():
    CASES = Path("/work/shared/cases")


class _Model:
    def __init__(self, d):
        self.name, self.sample_time_s = d["name"], d["sample_time_s"]
        self.inputs, self.outputs = d["inputs"], d["outputs"]
        self._p = {(o, i): mpmpp.TransferFunction(c["num"], c["den"], c.get("delay", 0))
                   for o, row in d["process"].items() for i, c in row.items()}
        self._n = {o: mpmpp.TransferFunction(c["num"], c["den"], 0) for o, c in d.get("noise", {}).items()}

    def process(self, output, input):
        return self._p.get((output, input))

    def noise(self, output):
        return self._n.get(output, mpmpp.TransferFunction())


def load_case(name: str):
    folder = CASES / name
    if hasattr(mpmpp, "load_model"):
        model = mpmpp.load_model(str(folder / "model.json"))
        return model, mpmpp.load_data(str(folder / "data.csv"), model), json.loads((folder / "answer.json").read_text())
    model = _Model(json.loads((folder / "model.json").read_text()))
    return model, pd.read_csv(folder / "data.csv"), json.loads((folder / "answer.json").read_text())
