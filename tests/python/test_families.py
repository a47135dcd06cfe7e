"""Scenario families (mpmpp.families): every family simulates, draws are reproducible, the
delay convention matches the data contract exactly, and the study's scoring."""
import copy
import math

import numpy as np
import pytest

import mpmpp
from mpmpp import families
from mpmpp.evaluate import nominal_model
from mpmpp.family_study import score
from mpmpp.scenario import parse_scenario

SHORT_S = 2 * 3600.0
NAMES = [f.name for f in families.FAMILIES]


@pytest.mark.parametrize("name", NAMES)
def test_every_family_simulates(name):
    fam = families.family(name)
    for seed in range(2):
        spec, expect = fam.draw(seed, record_s=SHORT_S)
        sc = parse_scenario(spec)
        assert len(sc.outputs) == fam.size and spec["sample_time_s"] in fam.sample_times_s
        df = mpmpp.simulate(spec)
        assert len(df) == sc.num_samples and np.isfinite(df.to_numpy()).all()
        model = nominal_model(spec)
        assert all(tuple(c) in set(model.channels()) for c in expect["channels"])
        if expect["kind"] != "none" or expect["effect"] != "none":
            assert any(ev["time_s"] == expect["onset_s"] for ev in spec["events"])


def test_draws_are_reproducible_and_seeds_differ():
    fam = families.family("mpc_2x2")
    assert fam.draw(3) == fam.draw(3)
    assert fam.draw(3)[0] != fam.draw(4)[0]


def test_split_and_coverage():
    """Both splits exist; the held-out set has controllers, sample times and noise colours the
    tuning set never uses; every effect of the vocabulary is scheduled somewhere. (Sizes are
    shared since 2026-12-01: the tuning family mpc_3x3 has three outputs, as the held-out 3x3
    families do with their own controllers, sample times and noise.)"""
    tuning = [f for f in families.FAMILIES if f.split == families.TUNING]
    held = [f for f in families.FAMILIES if f.split == families.HELD_OUT]
    assert tuning and held
    def seen(fs, attr):
        return {v for f in fs for v in (getattr(f, attr) if isinstance(getattr(f, attr), tuple)
                                        else (getattr(f, attr),))}
    for attr in ("controller", "sample_times_s", "noise_colours"):
        assert seen(held, attr) - seen(tuning, attr), attr
    effects = seen(families.FAMILIES, "effects")
    assert set(families.MPM_EFFECTS) | set(families.CONTROL_EFFECTS) | {"unmodeled_input"} <= effects
    assert {1, 2, 3} <= seen(families.FAMILIES, "size")
    assert min(seen(families.FAMILIES, "sample_times_s")) == 1.0 and max(seen(families.FAMILIES, "sample_times_s")) == 60.0


def first_change(x, start):
    moved = np.flatnonzero(np.abs(x[start:] - x[start]) > 1e-9 * max(1.0, abs(x[start])))
    return start + int(moved[0])


def contract_delay(channel, ts):
    """docs/formats.md: a discrete channel's `delay`; a FOPTD channel: its dead time in samples plus
    the zero-order hold's one sample (the first sample after theta)."""
    if "delay" in channel:
        return channel["delay"] + (np.flatnonzero(channel["num"])[0])
    return int(round(channel["dead_time_s"] / ts)) + 1


@pytest.mark.parametrize("name", ["mpc_siso", "pi_siso", "pid_siso_slow", "mpc_siso_fast", "pi_level"])
def test_delay_convention_matches_the_contract(name):
    """Noise off, one setpoint step at sample s: the controller moves u at s and y first
    responds at s + d, d the model file's delay (step at k -> response at k + d)."""
    for seed in range(3):
        spec, _ = families.family(name).draw(seed, record_s=SHORT_S)
        spec = copy.deepcopy(spec)
        ts = spec["sample_time_s"]
        spec["truth"]["sigma"] = {o: 0.0 for o in spec["outputs"]}
        spec["truth"].pop("outliers", None)
        spec["truth"].pop("extra", None)
        s = 100
        target = spec["controller"]["cv"]["y1"]["target"]
        spec["events"] = [{"time_s": s * ts, "type": "setpoint", "output": "y1", "value": target + 1.0}]
        df = mpmpp.simulate(spec)
        channel = spec["process"]["y1"]["u1"]
        d = contract_delay(channel, ts)
        assert first_change(df["u1"].to_numpy(), 1) == s
        assert first_change(df["y1"].to_numpy(), 1) == s + d
        # the model reader agrees: the loaded channel's impulse response starts at d
        g = nominal_model(spec).process("y1", "u1")
        assert g.delay + int(np.flatnonzero(np.abs(g.num) > 0)[0]) == d


def test_score():
    expect = {"kind": "mpm", "onset_s": 100.0, "channels": [["y1", "u1"]]}
    assert score({"G[y1 <- u1]": [150.0], "H[y1]": []}, expect) == {
        "false_mpm": False, "false_noise": False, "detected": True, "delay_s": 50.0, "mislocated": False,
        "read_as_noise": False}
    # missed, with the changed output's noise alarm after the change: read as a noise change
    assert score({"G[y1 <- u1]": [], "H[y1]": [150.0]}, expect)["read_as_noise"]
    assert not score({"G[y1 <- u1]": [], "H[y1]": [60.0], "H[y2]": [150.0]}, expect)["read_as_noise"]
    assert not score({"G[y1 <- u1]": [150.0], "H[y1]": [150.0]}, expect)["read_as_noise"]
    assert score({"H[y1]": [60.0, 150.0]}, expect)["false_noise"]
    assert not score({"H[y1]": [150.0]}, expect)["false_noise"]
    assert score({"G[y1 <- u1]": [50.0]}, expect)["false_mpm"]
    assert score({"G[y1 <- u2]": [120.0], "G[y1 <- u1]": []}, expect)["mislocated"]
    control = {"kind": "none", "onset_s": 100.0, "channels": []}
    assert score({"G[y1 <- u1]": [150.0]}, control) == {
        "false_mpm": True, "false_noise": False, "detected": None, "delay_s": None, "mislocated": None,
        "read_as_noise": None}
    # a noise change at 100 s: a noise alarm after it is right; with no change at all, none is
    assert not score({"H[y1]": [150.0]}, {**control, "effect": "noise_change"})["false_noise"]
    assert score({"H[y1]": [150.0]}, {**control, "effect": "none", "onset_s": None})["false_noise"]
    anything = {"kind": "any", "onset_s": 100.0, "channels": [["y1", "u1"]], "output": "y1"}
    assert score({"H[y1]": [130.0]}, anything)["detected"]
    assert not math.isnan(score({}, anything)["detected"])


def test_forced_effect():
    fam = families.family("pi_siso")
    spec, expect = fam.draw(5, effect="none")
    assert expect["effect"] == "none" and expect["kind"] == "none"
    with pytest.raises(ValueError, match="'output_drift' is not an effect of family pi_siso"):
        fam.draw(5, effect="output_drift")


def test_channel_switch_changes_only_the_record_after_the_onset():
    """The same draw with the changed channel started fresh: every event but the switch is the
    same, the record before the onset is identical and after it differs (the old channel's
    response to the earlier inputs fades instead of the new one replaying them)."""
    fam = families.family("mpc_2x2")
    spec, expect = fam.draw(3, None, "missing_coupling")
    fresh, expect_fresh = fam.draw(3, None, "missing_coupling", "fresh")
    assert expect_fresh == expect
    assert [{k: v for k, v in ev.items() if k != "switch"} for ev in fresh["events"]] == spec["events"]
    assert [ev.get("switch") for ev in fresh["events"] if ev["type"] == "process"] == ["fresh"]
    a, b = mpmpp.simulate(spec), mpmpp.simulate(fresh)
    k = int(round(expect["onset_s"] / spec["sample_time_s"]))
    assert np.array_equal(a.iloc[:k].to_numpy(), b.iloc[:k].to_numpy())
    assert np.abs(a["y1"].to_numpy()[k:] - b["y1"].to_numpy()[k:]).max() > 0.1
    with pytest.raises(ValueError, match="channel switch: 'swap' is not one of replay, fresh"):
        fam.draw(3, channel_switch="swap")


@pytest.mark.parametrize("name,effect", [("mpc_2x2", "gain"), ("mpc_3x3", "none"), ("mpc_siso_controls", "output_drift")])
def test_earlier_noise_change_adds_one_disturbance_change_before_the_effect(name, effect):
    """The same draw with one noise or level change added on the effect's output (a random one
    for a control without an output), at 35-70 % of the effect's onset or of 60 % of the record."""
    fam = families.family(name)
    spec, expect = fam.draw(4, None, effect)
    earlier, expect_earlier = fam.draw(4, None, effect, earlier_noise_change=True)
    added = [ev for ev in earlier["events"] if ev not in spec["events"]]
    assert len(added) == 1 and len(earlier["events"]) == len(spec["events"]) + 1
    assert [ev for ev in earlier["events"] if ev is not added[0]] == spec["events"]
    assert {k: v for k, v in expect_earlier.items() if k != "earlier_noise_change_s"} == expect
    ev = added[0]
    assert ev["type"] in ("noise", "sigma") and ev["time_s"] == expect_earlier["earlier_noise_change_s"]
    assert ev["time_s"] % spec["sample_time_s"] == 0
    reference = expect["onset_s"] or 0.6 * spec["duration_s"]
    assert 0.35 * reference - spec["sample_time_s"] <= ev["time_s"] <= 0.7 * reference
    if expect["channels"]:
        assert ev["output"] == expect["channels"][0][0]
    elif "output" in expect:
        assert ev["output"] == expect["output"]
    assert [e["time_s"] for e in earlier["events"]] == sorted(e["time_s"] for e in earlier["events"])


def test_cli_simulate_family_writes_data_and_a_model_file(tmp_path, capsys):
    from mpmpp.cli import main
    from mpmpp.io import load_data, load_model

    data, model = tmp_path / "d.csv", tmp_path / "m.json"
    assert main(["simulate", "--family", "pi_siso", "--seed", "3", "-o", str(data), "--write-model", str(model)]) == 0
    m = load_model(model)
    spec = families.family("pi_siso").scenario(3)
    assert "gain" in spec["process"]["y1"]["u1"]  # the FOPTD form, as a user would write it
    assert len(load_data(data, m)) == parse_scenario(spec).num_samples
    assert main(["evaluate", "--families", "no_such_family"]) == 2
    assert "unknown family 'no_such_family'" in capsys.readouterr().err
    assert main(["simulate", "--family", "pi_siso", "--paper", "siso", "-o", str(data)]) == 2


def test_by_effect_pools_runs_per_split_preset_kind_and_effect():
    from mpmpp.family_study import by_effect

    run = lambda split, effect, siso, paper: {  # noqa: E731
        "split": split, "expect": {"effect": effect},
        "presets": {"siso": {"detected": siso, "false_mpm": False}, "paper_siso": {"detected": None, "false_mpm": paper}}}
    cells = by_effect([run("tuning", "gain", True, True), run("tuning", "gain", False, False),
                       run("held_out", "none", None, True)])
    assert cells[0] == {"split": "tuning", "presets": "recommended", "effect": "gain", "runs": 2, "detected": 1,
                        "false_mpm": 0}
    assert {"split": "held_out", "presets": "paper", "effect": "none", "runs": 1, "detected": 0,
            "false_mpm": 1} in cells


def test_evidence_uses_the_true_disturbance_model():
    """The detection study's evidence for a change is the one-step likelihood ratio of the true
    change whitened by the scenario's true H (here a file without a noise model: the file's H = 1
    would whiten nothing), against a plain SciPy one-step error; none for a control."""
    from evidence_reference import reference_evidence

    from mpmpp.diagnosis_study import true_change
    from mpmpp.family_study import evidence
    from mpmpp.simulate import simulate

    spec, expect = families.family("pi_siso").draw(2, SHORT_S, effect="gain")
    assert "noise" not in spec
    data = simulate(spec)
    model = nominal_model({**spec, "noise": spec["truth"]["noise"]})
    change = true_change(spec, expect)
    k = int(round(expect["onset_s"] / spec["sample_time_s"]))
    want = reference_evidence(data, "y1", "u1", model.process_dict()["y1"]["u1"], change["channel"],
                              model.noise_dict()["y1"], k)
    assert want > 30.0
    assert evidence(spec, expect, data, change) == pytest.approx(want, rel=1e-6)
    spec, expect = families.family("pi_siso").draw(2, SHORT_S, effect="none")
    assert evidence(spec, expect, simulate(spec), true_change(spec, expect)) is None


def test_evidence_rows_bin_the_recommended_presets_runs():
    from mpmpp.family_study import evidence_rows

    run = lambda ev, detected, noise: {  # noqa: E731
        "split": "tuning", "evidence": ev,
        "presets": {"siso": {"detected": detected, "read_as_noise": noise},
                    "paper_siso": {"detected": True, "read_as_noise": False}}}
    rows = evidence_rows([run(5.0, False, False), run(500.0, True, False), run(800.0, False, True),
                          run(None, None, None)])
    assert rows == [{"split": "tuning", "bin": "[0, 10)", "changes": 1, "detected": 0, "read_as_noise": 0},
                    {"split": "tuning", "bin": "[100, 1000)", "changes": 2, "detected": 1, "read_as_noise": 1}]


def test_a_study_summary_names_what_its_draws_had_beside_the_family():
    assert families.variant_note({}) == ""
    assert families.variant_note({"channel_switch": "replay", "earlier_noise_change": False}) == ""
    assert families.variant_note({"channel_switch": "fresh", "earlier_noise_change": True}) == (
        "; channels switched fresh; an earlier noise change in every draw")
