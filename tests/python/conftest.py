"""Test-suite settings shared by every file."""
import sys
from pathlib import Path

from hypothesis import settings

# The studies' scenario generators (stiction_benchmark, diagnose_eval, example_cases) are
# importable in every test file, as the test helpers beside them are.
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "studies"))

# Property tests draw their examples from a fixed seed: a run is reproducible, and CI does
# not go red on an example no earlier run drew (fuzz_properties.py sets its own).
settings.register_profile("reproducible", derandomize=True)
settings.load_profile("reproducible")
