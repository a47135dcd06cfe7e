"""Lengths that scale with the record (mpmpp.record_length) and compare on short records."""
from __future__ import annotations

import pytest

import pi_loop
from mpmpp import _core
from mpmpp.compare import compare
from mpmpp.record_length import MIN_ROWS, minimum_rows, require_rows, scaled_rows


def test_preferred_length_when_the_record_holds_enough_pieces():
    assert scaled_rows(2161, 10.0, 3600.0, 3, 50) == 360        # 6 h at 10 s: 1 h segments


def test_a_share_of_a_short_record_never_below_the_floor():
    assert scaled_rows(751, 10.0, 3600.0, 3, 50) == 250         # 2 h at 10 s: thirds
    assert scaled_rows(120, 10.0, 3600.0, 3, 50) == 50


def test_minimum_and_the_too_short_line():
    assert minimum_rows(3, 60) == 180 and minimum_rows(3, 10) == MIN_ROWS
    require_rows(MIN_ROWS, 10.0)
    with pytest.raises(ValueError, match=r"^too short: 126 rows \(0.35 h\); need at least 150$"):
        require_rows(126, 10.0)


def _loop_model():
    g = _core.TransferFunction.from_foptd(pi_loop.FLOW.gain, pi_loop.FLOW.time_constant_s,
                                          pi_loop.FLOW.dead_time_s, 10.0)
    return _core.Model("flow", 10.0, ["OP"], ["PV"], {"PV": {"OP": g}})


def test_compare_scales_its_windows_to_a_two_hour_record():
    df = pi_loop.simulate(pi_loop.FLOW, seed=1, setpoint_steps=True)
    r = compare(_loop_model(), df)
    assert r.window_s == 1870.0                                  # 751 // 4 rows
    assert len(r.outputs[0].window_start_s) >= 8


def test_compare_on_a_126_row_record_says_too_short():
    df = pi_loop.simulate(pi_loop.FLOW, seed=1, rows=126)
    with pytest.raises(ValueError, match="too short: 126 rows"):
        compare(_loop_model(), df)
