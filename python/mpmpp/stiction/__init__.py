"""Valve stiction and other actuator nonlinearities from routine PI-loop data (OP, PV, SP).

``analyse_loop`` runs mpmpp's closed-loop Hammerstein fit (``hammerstein``) and the
literature baselines (Horch, Choudhury's bicoherence, Kano, He's curve fit) on one record.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..signals import longest
from .bicoherence import bicoherence_test
from .curve_fit import curve_fit_test
from .hammerstein import HammersteinResult, fit_valve
from .horch import horch_test
from .kano import kano_test
from .record_quality import record_notes

# The literature tests judge oscillation patterns and spectra of one unbroken series: below two of
# the bicoherence's 64-sample segments none of them is run (a 36-row stretch of a linear flow loop
# was "stiction" to Kano's test).
BASELINE_MIN_SAMPLES = 128

BASELINES = {
    "horch": lambda op, pv, sp: horch_test(op, pv),
    "bicoherence": bicoherence_test,
    "kano": lambda op, pv, sp: kano_test(op, pv),
    "curve_fit": lambda op, pv, sp: curve_fit_test(op, pv),
}


@dataclass
class LoopReport:
    mpmpp: HammersteinResult
    baselines: dict   # name -> (verdict, details)
    notes: list       # what the record's storage hides (record_quality)


def analyse_loop(op, pv, sp=None, names: tuple[str, str] = ("OP", "PV"), stretches=None) -> LoopReport:
    """mpmpp's fit, the baselines and the record's notes (``names``: OP's and PV's in them).
    ``stretches``: row ranges of consecutive complete samples (a record with missing values or
    gaps; default the whole record): mpmpp's fit uses them all, the baselines and the notes,
    which need one unbroken series, the longest; below BASELINE_MIN_SAMPLES the baselines are
    not run (verdict None, details ``{"not_run": why}``)."""
    op = np.asarray(op, float)
    pv = np.asarray(pv, float)
    sp = None if sp is None else np.asarray(sp, float)
    result = fit_valve(op, pv, stretches)
    rows = slice(*longest(stretches)) if stretches else slice(None)
    op, pv, sp = op[rows], pv[rows], None if sp is None else sp[rows]
    if len(op) < BASELINE_MIN_SAMPLES:
        why = (f"the longest unbroken stretch holds {len(op)} samples; the literature tests need "
               f"{BASELINE_MIN_SAMPLES}")
        baselines = {name: (None, {"not_run": why}) for name in BASELINES}
    else:
        baselines = {}
        for name, test in BASELINES.items():
            verdict, details = test(op, pv, sp)
            baselines[name] = (bool(verdict), details if isinstance(details, dict) else {"index": details})
    return LoopReport(result, baselines, record_notes(dict(zip(names, (op, pv)))))


__all__ = ["BASELINES", "HammersteinResult", "LoopReport", "analyse_loop", "fit_valve"]
