"""A model wrong from the record's start and changed later too (a user's hand-written FOPTD
model, the tuning family pi_siso_rough): diagnose reports the standing error and, from a second
pass against the model with it applied, the change (diagnose/pipeline.py _with_later_changes).
Sizes against the truth; the second pass runs only when a standing finding exists; update
applies a second-pass finding to the user's model as it is."""
import pytest

from mpmpp import families as fam
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose
from mpmpp.diagnose import pipeline
from mpmpp.diagnosis_study import true_change
from mpmpp.evaluate import nominal_model
from mpmpp.simulate import simulate
from mpmpp.step_response import step_response_error
from mpmpp.update import update

HOUR = 3600.0


@pytest.fixture(scope="module")
def rough_time_constant():
    """Seed 2: the model's gain is 1/1.15 of the plant's, its time constant 1/0.79; the plant's
    time constant doubles at 9.3 h (so it ends 1.58x the model's)."""
    spec, expect = fam.family("pi_siso_rough").draw(2, effect="time_constant")
    return spec, expect, nominal_model(spec), simulate(spec)


def _ratio(spec, key):
    return spec["truth"]["process"]["y1"]["u1"][key] / spec["process"]["y1"]["u1"][key]


def test_standing_error_and_later_change(rough_time_constant):
    spec, expect, model, data = rough_time_constant
    result = diagnose(model, data)
    process = [f for f in result.findings if f.effect in PROCESS_EFFECTS]
    standing = [f for f in process if f.onset_s <= data["time"].iloc[0]]
    later = [f for f in process if f.onset_s > data["time"].iloc[0]]
    assert [f.effect for f in standing] == ["gain"]
    assert standing[0].estimate["gain_ratio"] == pytest.approx(_ratio(spec, "gain"), rel=0.08)
    assert [f.effect for f in later] == ["time_constant"]
    change = later[0]
    assert abs(change.onset_s - expect["onset_s"]) < 1.0 * HOUR
    # the plant's time constant after the change, over the model's: 2 x 0.79
    assert change.estimate["time_constant_ratio"] == pytest.approx(2.0 * _ratio(spec, "time_constant_s"), rel=0.15)
    assert change.explanation.startswith(f"with {standing[0].id} applied")
    assert change.error_after < change.error_before
    assert set(result.process_parts) == {f.id for f in result.findings}


def test_update_with_the_later_change_moves_the_channel_to_the_plant(rough_time_constant):
    spec, expect, model, data = rough_time_constant
    result = diagnose(model, data)
    change = next(f for f in result.findings if f.effect == "time_constant")
    truth = true_change(spec, expect)["channel"]
    new = update(model, data, change.id).model
    before = step_response_error(model.process("y1", "u1"), truth)
    after = step_response_error(new.process("y1", "u1"), truth)
    assert after < 0.5 * before


def test_no_second_pass_without_a_standing_finding(monkeypatch):
    """The model equals the plant until a gain change (pi_siso): one pass, as before."""
    spec, _ = fam.family("pi_siso").draw(1, effect="gain")
    model, data = nominal_model(spec), simulate(spec)
    passes = []
    one_pass = pipeline._one_pass
    monkeypatch.setattr(pipeline, "_one_pass", lambda *a, **k: passes.append(1) or one_pass(*a, **k))
    result = diagnose(model, data)
    assert len(passes) == 1
    assert result.findings and all(f.onset_s > data["time"].iloc[0] for f in result.findings
                                   if f.effect in PROCESS_EFFECTS)
