"""The model as reference (config model_reference_significance, ChannelScorer::confirmation):
a process channel whose training agrees with the model is judged against the model and the
training mean together; a channel whose training shows the model wrong keeps the training mean
alone. The scores themselves are checked against NumPy in test_window_pooling.py."""
import copy
import json

import numpy as np
import pytest

from mpmpp import _core, families
from mpmpp.detect import Detector
from mpmpp.evaluate import nominal_model
from mpmpp.simulate import simulate


@pytest.fixture(scope="module")
def loop():
    spec, _ = families.family("pi_siso").draw(3, record_s=10 * 3600.0)
    return spec, simulate(spec)


def _process(detector):
    return [k for k, (kind, _, _) in enumerate(_core.WindowFeatures(detector.model, detector.config).channels)
            if kind == "process"]


def _scaled_gain(spec, factor):
    wrong = copy.deepcopy(spec)
    for channels in wrong["process"].values():
        for channel in channels.values():
            channel["gain"] = float(channel["gain"]) * factor
    return nominal_model(wrong)


def test_exact_model_is_the_reference(loop):
    spec, data = loop
    detector, _ = Detector._train(nominal_model(spec), data, None, "siso")
    for k in _process(detector):
        s = detector._core.scorers[k]
        assert s.model_p_value > detector.config.model_reference_significance
        assert s.confirmation == detector.config.training_confirmation == 0.05


def test_a_model_the_training_disproves_keeps_the_training_mean(loop):
    spec, data = loop
    model = _scaled_gain(spec, 1.6)  # written 60 % too high: the training sees it
    detector, _ = Detector._train(model, data, None, "siso")
    off, _ = Detector._train(model, data, None, {"preset": "siso", "model_reference_significance": 0})
    k = _process(detector)[0]
    assert 0 <= detector._core.scorers[k].model_p_value < 1e-6
    assert detector._core.scorers[k].confirmation == 0
    assert off._core.scorers[k].model_p_value == -1  # not tested
    assert [n for n in detector.notes if "G[y1 <- u1]: the training data reject the model" in n]
    assert not [n for n in off.notes if "reject" in n]
    np.testing.assert_array_equal(detector.monitor(data).scores[:, k], off.monitor(data).scores[:, k])


def test_intersection_union_is_never_more_negative_than_the_model_test(loop):
    """The confirmation can only keep a window from being negative: with it, a window's score
    is at least that of the test against the model alone (feature_mean and mean_covariance
    zeroed, confirmation off). A gain written 4 % high: the training does not reject it
    (p = 0.16), half the windows against the model do, and the confirmation keeps them normal
    (5 % high, the training rejects it since the whitening follows the disturbance's order)."""
    spec, data = loop
    detector, series = Detector._train(_scaled_gain(spec, 1.04), data, None, "siso")
    k = _process(detector)[0]
    assert detector._core.scorers[k].confirmation == 0.05
    scorers = list(detector._core.scorers)
    alone = _core.ChannelScorer()  # a copy: the property's elements are the detector's own
    for field in ("feature_scale", "reference_covariance", "significance", "training_windows"):
        setattr(alone, field, getattr(scorers[k], field))
    alone.feature_mean = np.zeros_like(np.asarray(scorers[k].feature_mean))
    alone.mean_covariance = np.zeros_like(np.asarray(scorers[k].mean_covariance))
    scorers[k] = alone
    core = detector._core
    model_only = _core.Detector(core.model, core.config, core.train_end_s, scorers).monitor_series(series)
    both = core.monitor_series(series)
    monitored = ~np.asarray(both.training)
    a, b = np.asarray(model_only.scores)[monitored, k], np.asarray(both.scores)[monitored, k]
    assert np.all(b >= a - 1e-12)
    assert np.mean(a < 0) >= 0.4 and not np.any(b < 0)  # no window negative with the confirmation


def test_detector_file_keeps_the_reference_and_version_9_loads_without_it(loop, tmp_path):
    spec, data = loop
    detector, _ = Detector._train(nominal_model(spec), data, None, "siso")
    path = tmp_path / "d.json"
    detector._core.save(str(path))
    again = _core.Detector.load(str(path))
    assert again.to_json() == detector._core.to_json()
    k = _process(detector)[0]
    assert again.scorers[k].confirmation == 0.05
    doc = json.loads(path.read_text())
    doc["version"] = 9
    for c in doc["channels"]:
        del c["confirmation"], c["model_p_value"]
    for key in ("model_reference_significance", "training_confirmation"):
        del doc["config"][key]
    old = _core.Detector.from_json(json.dumps(doc), "v9.json")
    assert old.scorers[k].confirmation == 0 and old.scorers[k].model_p_value == -1
    assert old.config.model_reference_significance == 0


@pytest.mark.parametrize("field, value", [("model_reference_significance", 1.0), ("training_confirmation", 0.0)])
def test_bad_reference_fields_name_themselves(loop, field, value):
    spec, data = loop
    with pytest.raises(ValueError, match=field):
        Detector._train(nominal_model(spec), data, None, {"preset": "siso", field: value})
