"""update cautions when the new model would make a controller act beyond a re-tuning: a
channel's gain cut below a quarter of the model's (a valve stuck or pinned at a limit of its
travel, more often than a process change) or its sign reversed."""
import pytest

from mpmpp import families
from mpmpp.diagnose.result import Finding
from mpmpp.diagnosis_study import nominal_model, simulate
from mpmpp.update import controller_cautions, update


def _finding(effect, ratio, fid="F1"):
    estimate = {} if ratio is None else {"gain_ratio": ratio}
    return Finding(id=fid, effect=effect, output="y1", input="u1", onset_s=0.0, confidence=0.9,
                   estimate=estimate, error_before=1.0, error_after=0.9, explanation="")


@pytest.mark.parametrize("effect,ratio,says", [
    ("gain", 2.0, None), ("gain", 0.5, None), ("gain", 0.26, None), ("noise_change", None, None),
    ("gain", 0.1, "cuts the gain of y1 <- u1 to 0.10x: a controller given this model moves u1 about 10 times"),
    ("time_constant", 0.2, "cuts the gain of y1 <- u1 to 0.20x: a controller given this model moves u1 about 5 times"),
    ("delay", -0.5, "F1 reverses the sign of y1 <- u1 (-0.50x the model's gain): a controller given this model "
                    "moves u1 the other way"),
    ("gain", 0.0, "cuts the gain of y1 <- u1 to 0x: a controller given this model moves u1 without bound"),
])
def test_a_caution_for_a_dead_or_reversed_channel_only(effect, ratio, says):
    cautions = controller_cautions([_finding(effect, ratio)])
    if says is None:
        assert cautions == []
    else:
        assert len(cautions) == 1 and says in cautions[0]


def test_a_pinned_valve_read_as_a_dead_gain_is_cautioned_in_update():
    """A tuning draw (mpc_siso_1s seed 7) whose valve saturates into a band the MPC's input has
    left: diagnose reads the channel as a gain of about 0.12x, and the update that writes it
    says a controller would move the input about 8 times as hard."""
    spec, _ = families.family("mpc_siso_1s").draw(7, None, "input_nonlinearity", "replay", False)
    model, data = nominal_model(spec), simulate(spec)
    result = update(model, data, "F1")
    top = result.diagnosis.finding("F1")
    assert top.effect == "gain" and 0.05 < top.estimate["gain_ratio"] < 0.25
    assert len(result.cautions) == 1 and "cuts the gain of y1 <- u1" in result.cautions[0]
    assert result.to_dict()["cautions"] == result.cautions
    assert f"caution: {result.cautions[0]}" in result.summary()
