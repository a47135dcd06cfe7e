"""Compressed and quantized loop records are named (mpmpp.stiction.record_quality): shares of
held and linearly interpolated samples against records built by hand."""
import json

import numpy as np
import pytest

from mpmpp.cli import main
from mpmpp.stiction import fit_valve
from mpmpp.stiction.record_quality import (interpolated_share, pinned_share, rate_limited_share, record_notes,
                                           repeated_share)


def noisy(n=751, seed=0):
    return np.cumsum(np.random.default_rng(seed).standard_normal(n)) * 0.1 + 50.0


def test_a_record_as_sampled_has_neither():
    x = noisy()
    assert repeated_share(x) == 0.0 and interpolated_share(x) == 0.0
    assert record_notes({"PV": x}) == []


def test_linear_interpolation_between_every_fifth_sample():
    x = noisy()
    kept = np.arange(0, 751, 5)                 # 0, 5, ..., 750: 150 gaps of 4 interpolated samples
    y = np.interp(np.arange(751), kept, x[kept])
    # the 4 samples of the steepest gap are the record's largest move (a rate limit's ramp looks so)
    assert interpolated_share(y) == pytest.approx(596 / 749, abs=1e-12)
    assert repeated_share(y) == 0.0
    (note,) = record_notes({"PV 'FIC101.PV'": y})
    assert note.startswith("PV 'FIC101.PV' lies on straight lines") and "80 %" in note


def test_holding_every_fourth_sample_and_a_saturated_op():
    x = noisy()
    held = np.repeat(x[::4], 4)[:751]            # three of every four moves are zero
    assert repeated_share(held) == pytest.approx(np.mean(np.diff(held) == 0.0), abs=0.01)
    assert repeated_share(held) > 0.7 and interpolated_share(held) == 0.0
    assert "repeats its previous value" in record_notes({"PV": held})[0]
    op = noisy(seed=1)
    op[200:500] = op.max()                       # at its limit (the record's largest value) for long
    assert np.mean(np.diff(op) == 0.0) > 0.2
    assert repeated_share(op) == 0.0
    (note,) = record_notes({"OP": op})           # not a quantized record: a limit
    assert note.startswith(f"OP sits at {op.max():.6g}, its largest value, in 40 % of the samples")


def test_an_op_that_returns_to_its_limit_is_named_and_quantization_is_not():
    """The stiction benchmark's saturated_op loops (the PI's output at a limit of its range,
    leaving it whenever the error reverses): the share is that of the samples at the limit; the
    benchmark's other loops, as sampled or quantized to 0.1 or 1 % OP, have no pile-up."""
    import stiction_benchmark as sb

    for dyn in sb.TUNING:
        rec = sb.make_record("tuning", dyn, "saturated_op", 0.0, 0.0, 11)
        share, value = pinned_share(rec["op"])
        assert value in (rec["op"].max(), rec["op"].min())
        assert share == pytest.approx(np.mean(rec["op"] == value)) and share > 0.05, dyn.name
        assert any(n.startswith(f"OP sits at {value:.6g}") for n in record_notes({"OP": rec["op"]}))
        for case in ("linear", "stiction", "external_oscillation"):
            op = sb.make_record("tuning", dyn, case, 3.0, 1.5, 11)["op"]
            for x in (op, np.round(op, 1), np.round(op)):
                assert pinned_share(x)[0] < 0.05, (dyn.name, case)


def test_an_op_ramping_at_its_rate_limit_is_not_compression():
    """An MPC's move limit: the OP moves by at most 0.4 per sample and often by exactly that,
    so it lies on straight lines as sampled; interpolating it between every fifth sample is
    still compression."""
    rng = np.random.default_rng(3)
    wanted = np.cumsum(rng.standard_normal(751)) * 1.5
    op = np.empty(751)
    op[0] = 50.0
    for t in range(1, 751):
        op[t] = op[t - 1] + np.clip(wanted[t] - op[t - 1] + 50.0, -0.4, 0.4)
    assert np.mean(np.abs(np.abs(np.diff(op)) - 0.4) < 1e-12) > 0.5   # the limit binds mostly
    assert interpolated_share(op) < 0.05
    assert rate_limited_share(op) == pytest.approx(np.mean(np.abs(np.abs(np.diff(op)) - 0.4) < 1e-12))
    (note,) = record_notes({"OP": op})                                   # a rate limit, not compression
    assert note.startswith("OP moves by its largest step in") and "no valve fault is reported" in note
    kept = np.arange(0, 751, 5)
    compressed = np.interp(np.arange(751), kept, op[kept])
    # the gaps over which the OP ramped at its limit anyway are the record as sampled
    assert interpolated_share(compressed) > 0.3 and "straight lines" in record_notes({"OP": compressed})[0]


def test_no_valve_verdict_on_a_rate_limited_op(monkeypatch, earlier_valve_fit):
    """A DMC clipping its moves (tuning family mpc_siso_clip, seed 7, no change: a linear valve):
    the OP moves by its limit in most samples and the valve fit with N_Y PV lags, free, calls a
    backlash; held to the limit, it calls nothing, and a free OP's largest move is rare. (With
    LONG_N_Y PV lags as well the fit itself finds the valve linear on this record, and so does
    the refined fit of 2026-12-03 with N_Y lags: the test keeps the earlier fit, which called it.)"""
    from mpmpp import families
    from mpmpp.simulate import simulate
    from mpmpp.stiction import hammerstein

    spec, _ = families.family("mpc_siso_clip").draw(7, effect="none")
    data = simulate(spec)
    op, pv = data["u1"].to_numpy(), data["y1"].to_numpy()
    assert rate_limited_share(op) > 0.7
    assert fit_valve(op, pv).kind == "linear"
    monkeypatch.setattr(hammerstein, "LONG_N_Y", hammerstein.N_Y)
    fit = fit_valve(op, pv)
    assert fit.kind == "backlash" and fit.confidence > 0.5   # what the fit alone would say
    assert not fit.verdict
    assert rate_limited_share(noisy()) < 0.01


def test_stiction_command_notes_a_compressed_pv(tmp_path, capsys):
    from test_stiction_cli import write_loop
    import pandas as pd

    data = tmp_path / "loop.csv"
    write_loop(data)
    main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV", "--json"])
    assert json.loads(capsys.readouterr().out)["notes"] == []
    df = pd.read_csv(data)
    kept = np.arange(0, len(df), 3)
    df["FIC101.PV"] = np.interp(np.arange(len(df)), kept, df["FIC101.PV"].to_numpy()[kept])
    df.to_csv(data, index=False)
    main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV", "--json"])
    (note,) = json.loads(capsys.readouterr().out)["notes"]
    assert note.startswith("PV 'FIC101.PV' lies on straight lines")
    assert main(["stiction", str(data), "--op", "FIC101.OP", "--pv", "FIC101.PV"]) == 0
    assert "note: PV 'FIC101.PV' lies on straight lines" in capsys.readouterr().out
