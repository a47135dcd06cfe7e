"""Test-suite settings shared by every file."""
from hypothesis import settings

# Property tests draw their examples from a fixed seed: a run is reproducible, and CI does
# not go red on an example no earlier run drew (fuzz_properties.py sets its own).
settings.register_profile("reproducible", derandomize=True)
settings.load_profile("reproducible")
