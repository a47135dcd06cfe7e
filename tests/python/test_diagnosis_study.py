"""The diagnosis study's scoring (python/mpmpp/diagnosis_study.py): the truth it reads from a
scenario, the tables' counts."""
from types import SimpleNamespace

import pytest

import mpmpp

from mpmpp import diagnosis_study as ds
from mpmpp import families as fam
from mpmpp.evaluate import nominal_model


@pytest.mark.parametrize("effect", ["gain", "delay", "missing_coupling", "input_nonlinearity", "output_drift", "none"])
def test_true_change_reads_the_scheduled_event(effect):
    spec, expect = fam.family("mpc_2x2").draw(3, effect=effect) if effect not in fam.CONTROL_EFFECTS \
        else fam.family("mpc_2x2_controls").draw(3, effect=effect)
    change = ds.true_change(spec, expect)
    if effect == "none":
        assert change is None
        return
    ev = next(e for e in spec["events"] if e["time_s"] == expect["onset_s"] and e["type"] not in ("setpoint",))
    nominal = nominal_model(spec).process_dict()
    if effect == "gain":
        g0 = nominal[ev["output"]][ev["input"]]
        assert change["channel"].dc_gain() == pytest.approx(ev["factor"] * g0.dc_gain())
        assert ds.finding_right({"effect": "gain", "output": ev["output"], "input": ev["input"]}, effect, change)
        assert not ds.finding_right({"effect": "delay", "output": ev["output"], "input": ev["input"]}, effect, change)
    elif effect == "delay":
        assert change["channel"].delay == ev["delay"]
    elif effect == "missing_coupling":
        assert ev["input"] not in nominal[ev["output"]]
        assert change["channel"].dc_gain() == pytest.approx(expect["size"], rel=1e-9)
    elif effect == "input_nonlinearity":
        assert change["input"] == ev["input"] and change["channel"] is None and change["actuator"] is not None
    else:
        assert change["output"] == ev["output"] and change["input"] is None
        assert ds.finding_right({"effect": "output_drift", "output": ev["output"]}, effect, change)


def test_a_noise_change_finding_is_right_at_an_earlier_noise_change():
    """With ``earlier_noise_change`` the added disturbance change is real: a noise_change finding
    on its output dated within an hour of it is right; one dated at the process change hours
    later (the change misread) and one on another output are not."""
    spec, expect = fam.family("mpc_2x2").draw(3, None, "gain", earlier_noise_change=True)
    changes = ds.noise_changes(spec)
    t, output = expect["earlier_noise_change_s"], expect["channels"][0][0]
    assert changes == [(output, t)]
    other = next(o for o in spec["outputs"] if o != output)

    def finding(effect, out, onset_s):
        return SimpleNamespace(effect=effect, output=out, onset_s=onset_s)
    assert ds.names_a_noise_change(finding("noise_change", output, t + 1800.0), changes)
    assert not ds.names_a_noise_change(finding("noise_change", output, expect["onset_s"]), changes)
    assert not ds.names_a_noise_change(finding("noise_change", other, t), changes)
    assert not ds.names_a_noise_change(finding("output_drift", output, t), changes)
    assert ds.noise_changes(fam.family("mpc_2x2").draw(3, None, "gain")[0]) == []


def test_tables_count_what_the_runs_say():
    def run(split, effect, right, false=False, update=None, conf=1.0):
        findings = [{"effect": "gain", "confidence": conf, "right": right}] if right or false else []
        top = {"effect": "gain", "onset_s": 5000.0} if (right or false) else None
        return {"family": f"a_{split}_family", "split": split, "effect": effect, "top_right": right, "false_process": false,
                "refused": None, "top_process": top, "findings": findings, "update": update, "onset_s": 3000.0}
    up = {"true_before": 1.0, "true_after": 0.4, "shown_before": 1.0, "shown_after": 0.9, "process_before": 1.0, "process_after": 0.3}
    bad = {"true_before": 1.0, "true_after": 1.2, "shown_before": 1.0, "shown_after": 0.99, "process_before": 1.0, "process_after": 0.9}
    runs = [run(fam.HELD_OUT, "gain", True, update=up), run(fam.HELD_OUT, "gain", False, update=bad, conf=0.7),
            run(fam.HELD_OUT, "none", False, True, conf=0.95),
            run(fam.TUNING, "none", False)]
    acc = {(r["split"], r["effect"]): r for r in ds.accuracy_rows(runs)}
    assert (acc[(fam.HELD_OUT, "gain")]["k"], acc[(fam.HELD_OUT, "gain")]["n"]) == (1, 2)
    assert acc[(fam.HELD_OUT, "none")]["k"] == 1 and acc[(fam.TUNING, "none")]["k"] == 0
    assert acc[(fam.HELD_OUT, "gain")]["dated"] == 1 and acc[(fam.HELD_OUT, "none")]["dated"] is None
    runs[0]["onset_s"] = 5000.0 - ds.DATED_WITHIN_S - 1.0      # named, but dated more than an hour off
    assert acc[(fam.HELD_OUT, "gain")]["dated"] == 1 and not ds.dated(runs[0])
    late = next(r for r in ds.accuracy_rows(runs) if (r["split"], r["effect"]) == (fam.HELD_OUT, "gain"))
    assert (late["k"], late["dated"], late["n"]) == (1, 0, 2)
    runs[0]["onset_s"] = 3000.0
    assert ds.onset_set_rows(runs) == []              # no finding carries an onset set
    runs[0]["top_process"].update(onset_earliest_s=2000.0, onset_latest_s=5240.0)   # holds 3000
    [onsets] = ds.onset_set_rows(runs)
    assert (onsets["split"], onsets["effect"], onsets["n"], onsets["held"], onsets["width_h"]) == (
        fam.HELD_OUT, "gain", 1, 1, pytest.approx(0.9))
    runs[0]["onset_s"] = 6000.0                       # outside the set (and not dated)
    assert ds.onset_set_rows(runs)[0]["held"] == 0
    runs[0]["onset_s"] = 3000.0
    upd = ds.update_rows(runs)[0]
    assert (upd["n"], upd["halved"], upd["misleading"]) == (2, 1, 1)   # the second: shown error fell, true rose
    rel = {(r["split"], r["bin"]): r for r in ds.reliability_rows(runs)}
    assert rel[(fam.HELD_OUT, "[0.99, 1]")]["n"] == 1 and rel[(fam.HELD_OUT, "[0.99, 1]")]["right"] == 1
    assert rel[(fam.HELD_OUT, "[0.9, 0.99)")]["n"] == 1 and rel[(fam.HELD_OUT, "[0.9, 0.99)")]["right"] == 0
    [held] = ds.reliability_by_effect(runs)   # the tuning run has no finding
    fams = {r["family"]: r for r in ds.family_rows(runs)}
    held_fam, tuning_fam = fams[f"a_{fam.HELD_OUT}_family"], fams[f"a_{fam.TUNING}_family"]
    assert (held_fam["right"], held_fam["changes"], held_fam["false"], held_fam["controls"]) == (1, 2, 1, 1)
    assert (held_fam["right_high"], held_fam["n_high"]) == (1, 2)   # the right gain at 1.0, the false one at 0.95
    assert (tuning_fam["changes"], tuning_fam["controls"], tuning_fam["n_high"]) == (0, 1, 0)
    runs[0]["evidence"], runs[1]["evidence"] = 250.0, 4.0
    ev = {r["bin"]: r for r in ds.evidence_rows(runs)}
    assert set(ev) == {"[0, 10)", "[100, inf)"}   # runs without an evidence are left out
    assert (ev["[100, inf)"]["n"], ev["[100, inf)"]["right"], ev["[0, 10)"]["right"]) == (1, 1, 0)
    assert (held["split"], held["effect"]) == (fam.HELD_OUT, "gain")
    assert (held["n"], held["right"], held["n_high"], held["right_high"]) == (2, 1, 2, 1)
    text = ds.format_tables({"runs": runs, "seeds": [0], "where": "x", "wall_seconds": 0.0})
    assert "| held_out | gain | 1/2 (50%) | 1/2 (50%) |" in text
    tables = [[line for line in block.splitlines() if line.startswith("|")] for block in text.split("\n\n")]
    tables = [t for t in tables if t]
    assert len(tables) == 8   # accuracy, two evidence tables, update, two reliability tables, onset sets, families
    for table in tables:      # every row as many cells as its header, the separator below it
        assert set(table[1].replace(" ", "")) == {"|", "-"}
        assert all(row.count("|") == table[0].count("|") for row in table)


def test_one_run_end_to_end():
    r = ds.run_diagnosis_seed("mpc_2x2", 1, "gain")
    assert r["top_right"] and r["update"]["true_after"] < 0.5 * r["update"]["true_before"]
    assert r["update"]["shown_after"] < r["update"]["shown_before"]


@pytest.mark.parametrize("name, seed, effect", [("pi_siso", 2, "gain"), ("mpc_2x2", 1, "missing_coupling")])
def test_a_channel_started_fresh_is_named_and_its_update_halves_the_error(name, seed, effect):
    """Another simulator's convention: the changed channel starts from rest at its onset and
    the old one's response fades (docs/scenario.md), not the replay diagnose's candidates
    mirror. The change is still named and sized (tuning draws; docs/diagnose.md "Channel switch")."""
    r = ds.run_diagnosis_seed(name, seed, effect, channel_switch="fresh")
    assert r["top_right"] and r["update"]["true_after"] < 0.5 * r["update"]["true_before"]


def test_true_evidence_is_the_one_step_likelihood_ratio_of_the_true_change():
    """Against the same statistic from a plain NumPy one-step error: y - G u filtered by H^-1,
    with the model's own channels and noise model (this draw has one: H = 1 / (1 - 0.6 q^-1))."""
    from evidence_reference import reference_evidence

    from mpmpp.simulate import simulate

    spec, expect = fam.family("mpc_siso").draw(1, effect="gain")
    model, data = nominal_model(spec), simulate(spec)
    change = ds.true_change(spec, expect)
    evidence = ds.true_evidence(model, data, change, expect["onset_s"])
    g0 = model.process_dict()["y1"]["u1"]
    k = int(round(expect["onset_s"] / spec["sample_time_s"]))
    assert evidence > 30.0
    want = reference_evidence(data, "y1", "u1", g0, change["channel"], model.noise_dict()["y1"], k)
    assert evidence == pytest.approx(want, rel=1e-6)
    # the true change written as the nominal channel carries no evidence
    assert ds.true_evidence(model, data, {**change, "channel": g0}, expect["onset_s"]) == 0.0


def test_true_evidence_of_a_saturation_is_that_of_the_clipped_input():
    """An actuator nonlinearity's evidence: the same statistic with the plant seeing the valve
    from the onset on, here a saturation, against the plain NumPy clip of the input."""
    from evidence_reference import reference_evidence

    from mpmpp.simulate import simulate

    spec, expect = fam.family("mpc_siso").draw(5, effect="input_nonlinearity")
    assert expect["nonlinearity"] == "saturation"
    ev = next(e for e in spec["events"] if e["type"] == "actuator")
    model, data = nominal_model(spec), simulate(spec)
    change = ds.true_change(spec, expect)
    evidence = ds.true_evidence(model, data, change, expect["onset_s"])
    g0 = model.process_dict()["y1"]["u1"]
    k = int(round(expect["onset_s"] / spec["sample_time_s"]))
    want = reference_evidence(data, "y1", "u1", g0, g0, model.noise_dict()["y1"], k, limits=(ev["min"], ev["max"]))
    assert evidence > 30.0
    assert evidence == pytest.approx(want, rel=1e-6)


def test_a_standing_finding_is_right_when_its_fix_removes_a_quarter_of_the_model_error():
    """Hand-written families: a finding from the first row is judged by how much of the model's
    own error (against the plant at the start) its update removes, not by its label."""
    from types import SimpleNamespace

    from mpmpp.diagnose.result import ModelChange
    from mpmpp.step_response import step_response_error

    spec, _ = fam.family("pi_siso_rough").draw(2, effect="none")
    model = nominal_model(spec)
    plant = nominal_model({**spec, "process": fam.plant_process(spec)})
    [out], [inp] = model.outputs, model.inputs
    truth = plant.process_dict()[out][inp]
    written = model.process_dict()[out][inp]
    before = step_response_error(written, truth)
    assert before > 0.05    # the drawn hand-written model is materially wrong

    def finding(channel):
        return SimpleNamespace(output=out, input=inp,
                               model_changes=lambda: [ModelChange(output=out, input=inp, channel=channel)])

    assert ds.standing_error_named(model, plant, finding(truth))         # the whole error removed
    assert not ds.standing_error_named(model, plant, finding(written))   # nothing removed
    # the written channel's gain scaled 10 % of the way to the plant's: under a quarter of the error
    k = written.dc_gain() + 0.1 * (truth.dc_gain() - written.dc_gain())
    partway = mpmpp.TransferFunction(list(map(float, written.num * k / written.dc_gain())), list(written.den), written.delay)
    fell = 1 - step_response_error(partway, truth) / before
    assert 0.0 < fell < ds.STANDING_ERROR_FALL
    assert not ds.standing_error_named(model, plant, finding(partway))
