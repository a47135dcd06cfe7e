"""Test-suite settings shared by every file."""
import importlib
import sys
from pathlib import Path

import pytest
from hypothesis import settings

# The studies' scenario generators (stiction_benchmark, diagnose_eval, example_cases) are
# importable in every test file, as the test helpers beside them are.
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "studies"))

# Property tests draw their examples from a fixed seed: a run is reproducible, and CI does
# not go red on an example no earlier run drew (fuzz_properties.py sets its own).
settings.register_profile("reproducible", derandomize=True)
settings.load_profile("reproducible")


@pytest.fixture
def earlier_valve_fit(monkeypatch):
    """The valve fit before 2026-12-03 (the size grid without refinement and its map, 380 and
    0.0034), in the fit and in diagnose's valve gate: for tests of what is done with a verdict
    that fit gave on a record the refined fit now calls linear."""
    from mpmpp.stiction import hammerstein

    monkeypatch.setattr(hammerstein, "REFINE_STEPS", 0)
    monkeypatch.setattr(hammerstein, "CAL_SLOPE", 380.0)
    for module in (hammerstein, importlib.import_module("mpmpp.diagnose.valve")):
        monkeypatch.setattr(module, "CAL_GAIN_AT_HALF", 0.0034)
