"""Model file: read against the json module, round trips, FOPTD, Python-built models."""
import json
import os

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy import signal

import mpmpp

from example_cases import CASES, EXAMPLES, MISSING_COUPLING, model_path
CASE_MODELS = [model_path(case) for case in CASES]


def test_example_cases_exist():
    assert all(path.is_file() for path in CASE_MODELS), f"example cases expected under {EXAMPLES}"


@pytest.mark.parametrize("path", CASE_MODELS, ids=lambda p: p.parent.name)
def test_load_matches_json_module(path):
    raw = json.loads(path.read_text())
    m = mpmpp.load_model(path)
    assert m.name == raw["name"]
    assert m.sample_time_s == raw["sample_time_s"]
    assert m.inputs == raw["inputs"] and m.outputs == raw["outputs"]
    expected = {(o, i) for o, row in raw["process"].items() for i in row}
    assert set(m.channels()) == expected
    for o in m.outputs:
        for i in m.inputs:
            g = m.process(o, i)
            if (o, i) not in expected:
                assert g is None
                continue
            ch = raw["process"][o][i]
            den0 = ch["den"][0]
            np.testing.assert_array_equal(g.num, np.array(ch["num"]) / den0)
            np.testing.assert_array_equal(g.den, np.array(ch["den"]) / den0)
            assert g.delay == ch.get("delay", 0)
        h = m.noise(o)
        if o in raw.get("noise", {}):
            np.testing.assert_array_equal(h.num, raw["noise"][o]["num"])
            np.testing.assert_array_equal(h.den, raw["noise"][o]["den"])
        else:
            assert h == mpmpp.TransferFunction()


@pytest.mark.parametrize("path", CASE_MODELS, ids=lambda p: p.parent.name)
def test_load_save_load_identical(path, tmp_path):
    m1 = mpmpp.load_model(path)
    mpmpp.save_model(m1, tmp_path / "a.json")
    m2 = mpmpp.load_model(tmp_path / "a.json")
    mpmpp.save_model(m2, tmp_path / "b.json")
    assert m1 == m2
    assert (tmp_path / "a.json").read_text() == (tmp_path / "b.json").read_text()
    # Same content as the original, whatever its formatting.
    assert json.loads((tmp_path / "a.json").read_text()) == json.loads(path.read_text())
    # The atomic write leaves no temporary file behind.
    assert sorted(os.listdir(tmp_path)) == ["a.json", "b.json"]


def foptd_model_text(gain, tau, theta, ts):
    return json.dumps({
        "name": "foptd", "sample_time_s": ts, "inputs": ["u"], "outputs": ["y"],
        "process": {"y": {"u": {"gain": gain, "time_constant_s": tau, "dead_time_s": theta}}},
    })


def test_foptd_channel_is_discretised_with_zoh(tmp_path):
    gain, tau, theta, ts = 1.5, 42.0, 20.0, 5.0  # dead time = 4 samples
    path = tmp_path / "m.json"
    path.write_text(foptd_model_text(gain, tau, theta, ts))
    g = mpmpp.load_model(path).process("y", "u")
    # Reference: scipy ZOH of K/(T s + 1), then 4 samples of pure delay.
    numd, dend, _ = signal.cont2discrete(([gain], [tau, 1.0]), ts, method="zoh")
    ref = np.convolve(np.r_[np.zeros(4), np.ravel(numd)], [1.0])
    expected = signal.lfilter(ref, dend, np.ones(100))
    np.testing.assert_allclose(g.step(100), expected, rtol=0, atol=1e-12)


def test_foptd_written_in_discrete_form_and_round_trips(tmp_path):
    src = tmp_path / "m.json"
    src.write_text(foptd_model_text(2.0, 30.0, 12.5, 5.0))
    m1 = mpmpp.load_model(src)
    mpmpp.save_model(m1, tmp_path / "out.json")
    written = json.loads((tmp_path / "out.json").read_text())
    assert set(written["process"]["y"]["u"]) == {"num", "den", "delay"}
    m2 = mpmpp.load_model(tmp_path / "out.json")
    assert m2 == m1
    assert m2.process("y", "u") == mpmpp.TransferFunction.from_foptd(2.0, 30.0, 12.5, 5.0)


def test_model_built_from_python():
    g = mpmpp.TransferFunction([0.1], [1.0, -0.9], 3)
    h = mpmpp.TransferFunction([1.0, 0.2], [1.0, -0.5])
    m = mpmpp.Model("built", 2.0, ["u1", "u2"], ["y"], {"y": {"u2": g}}, {"y": h})
    assert m.process("y", "u2") == g and m.process("y", "u1") is None
    assert m.noise("y") == h
    assert m.channels() == [("y", "u2")]
    again = mpmpp.Model(m.name, m.sample_time_s, m.inputs, m.outputs, m.process_dict(), m.noise_dict())
    assert again == m
    assert mpmpp.Model.from_json(m.to_json()) == m
    assert m != "not a model"


@pytest.mark.parametrize("kwargs, message", [
    (dict(process={"z": {}}), 'process.z: unknown output "z"'),
    (dict(process={"y": {"w": mpmpp.TransferFunction()}}), 'process.y.w: unknown input "w"'),
    (dict(noise={"y": mpmpp.TransferFunction([2.0], [1.0])}), "noise.y: must be monic"),
    (dict(noise={"y": mpmpp.TransferFunction([1.0], [1.0, -1.2])}), "noise.y: unstable"),
    (dict(noise={"y": mpmpp.TransferFunction([1.0, 2.0], [1.0])}), "noise.y: non-minimum-phase"),
    (dict(sample_time_s=0.0), "sample_time_s: must be > 0"),
    (dict(inputs=["u", "u"]), 'inputs[1]: duplicate name "u"'),
    (dict(outputs=[]), "outputs: must name at least one variable"),
])
def test_model_built_from_python_is_validated(kwargs, message):
    args = dict(name="m", sample_time_s=1.0, inputs=["u"], outputs=["y"])
    args.update(kwargs)
    with pytest.raises(ValueError) as err:
        mpmpp.Model(**args)
    assert str(err.value).startswith(message)


def test_save_into_missing_directory_names_the_file(tmp_path):
    m = mpmpp.load_model(CASE_MODELS[0])
    target = tmp_path / "nope" / "m.json"
    with pytest.raises(ValueError, match=f"^{target}: cannot write: "):
        mpmpp.save_model(m, target)


GOOD_TEXT = model_path(MISSING_COUPLING).read_text()


@settings(max_examples=200, deadline=None)
@given(cut=st.integers(0, len(GOOD_TEXT)), insert=st.text(max_size=8))
def test_mangled_model_text_gives_a_one_line_error_or_a_model(cut, insert):
    text = GOOD_TEXT[:cut] + insert + GOOD_TEXT[cut + len(insert):]
    try:
        mpmpp.Model.from_json(text, "m.json")
    except ValueError as exc:
        assert str(exc).startswith("m.json: ") and "\n" not in str(exc)
