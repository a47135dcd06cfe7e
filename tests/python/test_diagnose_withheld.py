"""Per output, diagnose keeps the channel findings of the input whose finding explains most and
names the others in a note (diagnose/pipeline.py, _strongest_input_per_output): a missing
coupling from u2 into y1 makes y1's own controller move u1 differently, and before this rule an
actuator on u1 fitted part of it, at confidence up to 0.96 (tuning family mpc_2x2_spiky)."""
from mpmpp import families
from mpmpp.diagnose import diagnose
from mpmpp.diagnose.pipeline import CHANNEL_EFFECTS
from mpmpp.evaluate import nominal_model
from mpmpp.simulate import simulate


def test_a_missing_coupling_is_not_also_read_as_an_actuator_of_the_output_own_input():
    spec, _ = families.family("mpc_2x2_spiky").draw(1, effect="missing_coupling")
    coupling = next(ev for ev in spec["events"] if ev["type"] == "process")
    output, new_input = coupling["output"], coupling["input"]
    res = diagnose(nominal_model(spec), simulate(spec))
    channel = [f for f in res.findings if f.effect in CHANNEL_EFFECTS and f.output == output]
    assert [(f.effect, f.input) for f in channel] == [("missing_coupling", new_input)]
    withheld = [n for n in res.notes if "withheld" in n]
    assert withheld and all(f"-> {output}" in n and new_input in n for n in withheld)
