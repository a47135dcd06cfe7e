"""Diagnosis: which physical effect is missing from the model, where and since when.

Method (docs/diagnose.md has the long form), per output:

1. ``whitening``: residual statistics over time; a two-segment AR split of the one-step error
   gives each side its own noise correction, so the residual is whitened whatever the
   disturbance did.
2. ``process``: candidate channel changes (``shapes``: gain, time constant, delay, missing
   coupling, unmodeled input, output drift; their whitened ``responses``), each fitted from an
   onset on and scored on held-out 1 h blocks; ``valve``: a single loop's (``loops``) sticking valve by the closed-loop Hammerstein
   fit; ``actuator``: backlash / stick-slip on an input that drives several outputs.
3. ``noise``: noise change and drift on outputs without a process finding.
4. ``pipeline``: findings are accepted greedily and ranked by score; ``errors`` gives the
   reported error before / after on held-out blocks; ``result`` holds the records, ``plots``
   the figures.
"""
from .errors import one_step_errors
from .pipeline import diagnose
from .result import EFFECTS, PROCESS_EFFECTS, DiagnoseResult, Finding, HeldOutError, ModelChange

__all__ = ["EFFECTS", "PROCESS_EFFECTS", "DiagnoseResult", "Finding", "HeldOutError", "ModelChange",
           "diagnose", "one_step_errors"]
