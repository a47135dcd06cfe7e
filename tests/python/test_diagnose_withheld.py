"""Findings diagnose withholds, with a note (diagnose/pipeline.py).

Per output, the channel findings of the input whose finding explains most are kept and the
others named (_strongest_input_per_output): a missing coupling from u2 into y1 makes y1's own
controller move u1 differently, and before this rule an actuator on u1 fitted part of it, at
confidence up to 0.96 (tuning family mpc_2x2_spiky). A linear channel change present from the
first row stays only when the process part confirms it (_without_unconfirmed_standing_changes).
"""
import numpy as np
import pytest

from mpmpp import TransferFunction, families
from mpmpp.diagnose import diagnose
from mpmpp.diagnose.errors import one_step_errors
from mpmpp.diagnose.pipeline import (HALF_BLOCKS, _refitted_gains_per_half,
                                    _without_unconfirmed_standing_changes, diagnosis_signals)
from mpmpp.diagnose.process_error import held_out_rms, process_parts
from mpmpp.diagnose.result import PROCESS_EFFECTS, Finding, ModelChange
from mpmpp.diagnose.whitening import output_residual
from mpmpp.evaluate import nominal_model
from mpmpp.simulate import simulate

import closed_loop_case as loop


def test_a_missing_coupling_is_not_also_read_as_an_actuator_of_the_output_own_input():
    spec, _ = families.family("mpc_2x2_spiky").draw(1, effect="missing_coupling")
    coupling = next(ev for ev in spec["events"] if ev["type"] == "process")
    output, new_input = coupling["output"], coupling["input"]
    res = diagnose(nominal_model(spec), simulate(spec))
    channel = [f for f in res.findings if f.effect in PROCESS_EFFECTS and f.output == output]
    assert [(f.effect, f.input) for f in channel] == [("missing_coupling", new_input)]
    assert not any(f.effect == "input_nonlinearity" for f in res.findings)
    # the actuator of the output's own input, when its search proposes one, is withheld in
    # favour of the coupling (with the actuator widths refined, 2026-12-03, none is proposed)
    withheld = [n for n in res.notes if "withheld" in n]
    assert all(f"-> {output}" in n and new_input in n for n in withheld)


def standing_gain(model, ratio, onset_s=0.0):
    """A gain finding on the test loop's channel: ``ratio`` times the model's, from ``onset_s``."""
    g = model.process("y", "u")
    change = ModelChange(output="y", input="u", channel=TransferFunction(np.asarray(g.num) * ratio, g.den, g.delay))
    return Finding(id="", effect="gain", output="y", input="u", onset_s=onset_s, confidence=0.9, estimate={},
                   error_before=1.0, error_after=0.9, explanation=f"gain {ratio}x", change=change)


def _judged(n, plant_gain, plant_onset, found):
    """_without_unconfirmed_standing_changes on the closed-loop test loop (n rows, 720-row
    blocks) for a gain ``found`` times the model's from the first row."""
    model = loop.model()
    prepared = diagnosis_signals(model, loop.simulate(n=n, seed=3, onset=plant_onset, gain=plant_gain))
    out = output_residual(prepared.sig, 0, 720, 0, 720)
    finding = standing_gain(model, found)
    return prepared, out, finding, _without_unconfirmed_standing_changes([finding], prepared, [out], 0, 720, np.log(n))


@pytest.mark.parametrize("plant_gain, plant_onset, found, kept",
                         [(1.0, 0, 1.5, False), (2.0, 0, 2.0, True), (2.0, 4000, 1.2, False)])
def test_a_change_throughout_stays_only_when_the_process_part_confirms_it(plant_gain, plant_onset, found, kept):
    """A gain change present from the first row, on the closed-loop test loop whose plant gain is
    ``plant_gain`` times the model's from ``plant_onset`` (9000 rows: each half holds
    HALF_BLOCKS blocks or more): a 1.5x on an exact model raises the held-out process-part error
    and is withheld with a note; the true 2x throughout lowers it in both halves of the record
    and stays; a 1.2x throughout where the plant doubled at row 4000 lowers the whole
    record's process-part error but raises the first half's, and is withheld. The same 1.5x
    with an onset is not this rule's to judge."""
    prepared, out, finding, (got, notes) = _judged(9000, plant_gain, plant_onset, found)
    assert 9000 >= 2 * HALF_BLOCKS * 720
    assert (got == [finding]) == kept
    assert bool(notes) != kept and all("withheld" in n and "both halves" in n for n in notes)
    if plant_onset:   # the whole record's process part alone would have kept it
        before, after = (held_out_rms(p, 720) for p in process_parts(prepared.sig, 0, finding.model_changes(), 0, 720))
        assert after < before
    later = standing_gain(loop.model(), found, onset_s=float(prepared.sig.time_s[4000]))
    assert _without_unconfirmed_standing_changes([later], prepared, [out], 0, 720, np.log(9000)) == ([later], [])


@pytest.mark.parametrize("plant_gain, plant_onset, found, kept",
                         [(1.0, 0, 1.5, False), (2.0, 0, 2.0, True), (2.0, 2000, 1.2, False)])
def test_on_a_short_record_each_half_must_carry_the_change_in_the_one_step_error(plant_gain, plant_onset, found,
                                                                                 kept):
    """4000 rows of 720-row blocks: the halves are too short for their own process-part fits, so
    the process part is judged over the whole record and each half must carry the change in
    the one-step error, with the AR correction refitted beside it. The true 2x throughout
    stays; the 1.2x averaged over a doubling halfway through lowers the whole record's errors
    but not the first half's one-step error, and is withheld with a note naming both halves."""
    prepared, out, finding, (got, notes) = _judged(4000, plant_gain, plant_onset, found)
    assert (got == [finding]) == kept
    if plant_onset:
        before, after = (held_out_rms(p, 720) for p in process_parts(prepared.sig, 0, finding.model_changes(), 0, 720))
        assert after < before
        first, second = _refitted_gains_per_half(out, one_step_errors(prepared.sig, 0, finding.model_changes()),
                                                 0, 2000)
        assert first <= np.log(4000) < second
        [note] = notes
        assert "not above log N" in note and "both halves" in note


def test_a_change_throughout_must_hold_with_the_noise_model_fitted_without_the_inputs():
    """An exact model without a noise model under an MPC whose moves are clipped, dead time one
    sample (tuning family mpc_siso_clip, seed 10, no change): the noise model estimated beside
    the inputs' basis takes part of the disturbance the controller reacted to, and the process
    part whitened with it confirmed a gain 0.68x throughout. Fitted to the output error alone,
    the noise model does not confirm it, and the finding is withheld with a note. The search for
    a change later in the record that follows finds none the scan dates inside the record."""
    spec, _ = families.family("mpc_siso_clip").draw(10, effect="none")
    model, data = nominal_model(spec), simulate(spec)
    prepared = diagnosis_signals(model, data)
    assert prepared.estimated_noise == ["y1"]
    with_file_noise = diagnosis_signals(loop.model(), loop.simulate(n=3000, seed=1))
    assert with_file_noise.without_input_basis("y") is None   # the file's noise model is not re-estimated
    res = diagnose(model, data)
    assert not [f for f in res.findings if f.effect in PROCESS_EFFECTS]
    [note] = [n for n in res.notes if "withheld" in n]
    assert note.startswith("gain of y1 <- u1") and "either estimate of its noise model" in note


def test_a_dated_change_the_data_fit_as_well_from_the_start_is_judged_as_present_throughout():
    """Tuning family mpc_level, seed 1, a noise-change control (the process unchanged): the
    search dates a gain at 3.4 h whose onset set reaches back to the record's start, so the
    data cannot tell it from a model error present throughout. Judged as one, its update does
    not lower the process part in both halves; withheld with a note, the output's finding is
    the noise change, which is the truth."""
    spec, _ = families.family("mpc_level").draw(1, effect="noise_change")
    res = diagnose(nominal_model(spec), simulate(spec))
    assert not [f for f in res.findings if f.effect in PROCESS_EFFECTS]
    [note] = [n for n in res.notes if "judged as present throughout" in n]
    assert note.startswith("gain of y1 <- u1") and "any onset from" in note
    assert [f.effect for f in res.findings] == ["noise_change"]


def test_a_change_later_in_the_record_is_searched_once_the_change_throughout_is_withheld():
    """Tuning family mpc_siso_1s, seed 1: the plant's gain doubles at 36,200 s under an MPC at
    2 s. The first search reads a time constant 0.46x throughout (its step + ramp disturbances
    chosen beside it), which the process part does not confirm; withheld, the output got an
    output drift. Searched again for changes with an onset, the refused time constant left out,
    the doubled gain is named where it happened, its size within the profile's reach."""
    spec, expect = families.family("mpc_siso_1s").draw(1, effect="gain")
    assert expect["size"] == 2.0
    res = diagnose(nominal_model(spec), simulate(spec))
    assert any(n.startswith("time constant of y1 <- u1") and "withheld" in n for n in res.notes)
    top = next(f for f in res.findings if f.effect in PROCESS_EFFECTS)
    assert (top.effect, top.output, top.input) == ("gain", "y1", "u1")
    assert abs(top.onset_s - expect["onset_s"]) <= 600.0
    assert 1.6 <= top.estimate["gain_ratio"] <= 2.6


def test_a_later_change_the_rows_before_it_do_not_reject_is_withheld():
    """Tuning family pi_siso_brief, seed 15, a noise-change control on a hand-written model: its
    own error, a time constant 1.37x throughout, is withheld (short record: the second half's
    refitted gain 2.4 < log N), and the search for a later change finds a dead time from 1.0 h,
    the first onset the scan allows. Its first hour does not reject it, so it is the model's
    error again, not a change: withheld with a note, and the noise change is reported."""
    spec, _ = families.family("pi_siso_brief").draw(15, effect="noise_change")
    res = diagnose(nominal_model(spec), simulate(spec))
    assert not [f for f in res.findings if f.effect in PROCESS_EFFECTS]
    [later] = [n for n in res.notes if "the rows before its onset do not reject it" in n]
    # the model file's FOPTD dead time (5 s) is the one quoted, not its first lag times Ts (10 s)
    assert spec["process"]["y1"]["u1"]["dead_time_s"] == 5
    assert later.startswith("dead time of y1 <- u1 about 10 s instead of 5 s (delay 3 samples instead of 2)")


def test_a_change_later_in_the_record_is_searched_once_a_dropped_change_throughout_is_refused():
    """Tuning family pi_level, seed 0: the level's inflow gain falls to 0.625x at 37,910 s. The
    first search's best, beside step + ramp disturbances it chose at the change, is a dead time
    throughout whose update raises the held-out one-step error: dropped in the search, it left
    the output to an output drift. Refused like a withheld one, the search for changes with an
    onset names the gain where it happened."""
    spec, expect = families.family("pi_level").draw(0, effect="gain")
    assert expect["size"] == 0.625
    res = diagnose(nominal_model(spec), simulate(spec))
    top = next(f for f in res.findings if f.effect in PROCESS_EFFECTS)
    assert (top.effect, top.output, top.input) == ("gain", "y1", "u1")
    assert abs(top.onset_s - expect["onset_s"]) <= 600.0
    assert 0.5 <= top.estimate["gain_ratio"] <= 0.75
