"""Closed-loop simulation of a scenario -> data in docs/formats.md's layout."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from . import _core
from .scenario import Scenario, load_scenario, parse_scenario


def as_scenario(scenario: Scenario | dict | str | Path) -> Scenario:
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, dict):
        return parse_scenario(scenario)
    return load_scenario(scenario)


def run(scenario: Scenario | dict | str | Path, seed: int | None = None, record_qps: bool = False):
    """The engine's SimulationResult (u, u_actual, y, setpoint, extra, and with record_qps
    every QP: qp_P, qp_A fixed, qp_q / qp_l / qp_u one row per sample)."""
    sc = as_scenario(scenario)
    return _core.simulate_closed_loop(sc.to_config(seed, record_qps))


def simulate(scenario: Scenario | dict | str | Path, seed: int | None = None) -> pd.DataFrame:
    """Simulate `scenario` (a Scenario, a scenario dict or a JSON path) and return the data
    table of docs/formats.md: time (s from 0), one column per input (the MV commands) and output,
    ``<output>_sp`` (CV target in force) and one column per extra measured variable.
    ``seed`` overrides the scenario's seed; the same seed gives the same data."""
    sc = as_scenario(scenario)
    return frame(sc, _core.simulate_closed_loop(sc.to_config(seed)))


def frame(sc: Scenario, res) -> pd.DataFrame:
    """A SimulationResult as the data table (see simulate)."""
    n = sc.num_samples
    cols = {"time": np.arange(n) * sc.sample_time_s}
    for j, name in enumerate(sc.inputs):
        cols[name] = res.u[:, j]
    for i, name in enumerate(sc.outputs):
        cols[name] = res.y[:, i]
    for i, name in enumerate(sc.outputs):
        cols[f"{name}_sp"] = res.setpoint[:, i]
    for k, name in enumerate(sc.extra_names):
        cols[name] = res.extra[:, k]
    df = pd.DataFrame(cols)
    df.attrs["scenario"] = sc.name
    df.attrs["failed_solves"] = int(res.failed_solves)
    df.attrs["event_times_s"] = sorted({e.sample * sc.sample_time_s for e in sc.events})
    return df
