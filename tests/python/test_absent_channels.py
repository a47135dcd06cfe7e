"""Channels the model lacks (config absent_channels, residual_regression.hpp): a coupling that
appears where the model file has none gets a process channel of its own. The window regression
against the plain NumPy reference, its null distribution on the right model, an end-to-end
alarm on an appearing coupling, and the detector file and streaming path with such channels."""
import json

import numpy as np
import pytest

import mpmpp
from mpmpp import StreamingDetector, _core
from mpmpp import families as fam
from mpmpp.detect import Detector, detect, make_config
from mpmpp.evaluate import nominal_model
from mpmpp.simulate import simulate
from residual_reference import reference_window_miso

COUPLING_SEED = 1  # mpc_2x2: y2 <- u1 appears at 11.1 h (gain 1.6, evidence ~190,000 units)


@pytest.fixture(scope="module")
def coupling_run():
    spec, expect = fam.family("mpc_2x2").draw(COUPLING_SEED, effect="missing_coupling")
    return spec, expect, nominal_model(spec), simulate(spec)


def _absent_output(model):
    """(output index, [input indices]) of the first output with a channel the model lacks."""
    for i, o in enumerate(model.outputs):
        if any((o, u) not in model.channels() for u in model.inputs):
            return i, list(range(len(model.inputs)))
    raise AssertionError("every channel is modelled")


def test_presets_monitor_absent_channels():
    model = nominal_model(fam.family("mpc_2x2").draw(0)[0])
    config = make_config("mimo", model)
    assert config.absent_channels == 2 and 0 < config.absent_significance < config.window_significance
    labels = [(k, i, j) for k, i, j in _core.WindowFeatures(model, config).channels]
    process = [(i, j) for k, i, j in labels if k == "process"]
    assert len(process) == len(model.inputs) * len(model.outputs) > len(model.channels())
    for modelled_only in ("paper_mimo", {"preset": "mimo", "process_test": "svm", "noise_test": "wald"}):  # no estimate for them
        c = make_config(modelled_only, model)
        assert sum(k == "process" for k, _, _ in _core.WindowFeatures(model, c).channels) == len(model.channels())


@pytest.mark.parametrize("lost_rows", [False, True])
def test_window_matches_numpy(coupling_run, lost_rows):
    """One 2 h window of an output that lacks a channel: beta and its covariance of the modelled
    and the absent channel against reference_window_miso (breaks and outlier rows included);
    with ``lost_rows``, three rows a historian lost (every column missing)."""
    _, _, model, data = coupling_run
    i, inputs = _absent_output(model)
    config = make_config("mimo", model)
    n = config.window_samples(model.sample_time_s)
    y = data[model.outputs[i]].to_numpy()[:n].copy()
    u = data[list(model.inputs)].to_numpy()[:n].copy()
    if lost_rows:
        rows = [n // 5, n // 2, n // 2 + 1]
        y[rows] = np.nan
        u[rows] = np.nan
    beta, cov, settle = _core.residual_regression(model, i, inputs, config, y, u)
    channels = [model.process(model.outputs[i], model.inputs[j]) if (model.outputs[i], model.inputs[j])
                in model.channels() else None for j in inputs]
    assert None in channels and any(g is not None for g in channels)
    ref_b, ref_c, _, _ = reference_window_miso(channels, y, u, config.arx_order_a, config.laguerre_terms,
                                               config.absent_channels, settle, config.residual_steps,
                                               config.step_significance, config.outlier_sigmas)
    for e, g in enumerate(channels):
        assert len(beta[e]) == (config.absent_channels if g is None else 3 + config.laguerre_terms)
        np.testing.assert_allclose(beta[e], ref_b[e], rtol=1e-6, atol=1e-9 * np.abs(ref_b[e]).max())
        np.testing.assert_allclose(cov[e], ref_c[e], rtol=1e-6, atol=1e-9 * np.abs(ref_c[e]).max())


def _wald(beta, cov):
    w, V = np.linalg.eigh(cov)
    keep = w > 1e-9 * w.max()
    z = V[:, keep].T @ beta
    return float(np.sum(z**2 / w[keep])), int(keep.sum())


def test_null_distribution_is_chi_square():
    """The right model (controls without change), disjoint windows over three seeds: an absent
    channel's Wald statistic against zero averages near 1 per degree of freedom."""
    ratios = []
    for seed in range(3):
        spec, _ = fam.family("mpc_2x2_controls").draw(seed, effect="none")
        model = nominal_model(spec)
        data = simulate(spec)
        config = make_config("mimo", model)
        n = config.window_samples(spec["sample_time_s"])
        i, inputs = _absent_output(model)
        absent = [e for e, j in enumerate(inputs) if (model.outputs[i], model.inputs[j]) not in model.channels()]
        y, u = data[model.outputs[i]].to_numpy(), data[list(model.inputs)].to_numpy()
        for a in range(0, len(y) - n + 1, n):
            beta, cov, _ = _core.residual_regression(model, i, inputs, config, y[a:a + n], u[a:a + n])
            for e in absent:
                T, dof = _wald(beta[e], cov[e])
                ratios.append(T / dof)
    assert len(ratios) >= 15
    assert 0.5 < np.mean(ratios) < 1.6, np.round(ratios, 2)


def test_detect_alarms_on_the_appearing_coupling(coupling_run):
    """The coupling the model lacks raises an MPM alarm on its own channel after it appears and
    none before; without absent channels it reaches the test only through the modelled channel
    of its output, later (measured 12.6 h against 12.9 h, the coupling from 11.5 h; no MPM
    alarm at all with the AR(18) whitening used before 2026-11-29)."""
    spec, expect, model, data = coupling_run
    o, u = expect["absent_channel"]
    assert (o, u) not in model.channels()
    result = detect(model, data, config="mimo")
    t0 = float(data["time"].iloc[0])
    k = next(k for k, c in enumerate(result.channels) if c["kind"] == "process" and (c["output"], c["input"]) == (o, u))
    assert result.channels[k]["in_model"] is False
    starts = result.alarm_starts(k) - t0
    assert len(starts) and starts[0] > expect["onset_s"]
    assert all(a["start_s"] - t0 > expect["onset_s"] for a in result.alarms if a["kind"] == "process")
    doc = result.to_dict()
    assert {"kind": "process", "output": o, "input": u, "in_model": False} in doc["channels"]
    without = detect(model, data, config={"preset": "mimo", "absent_channels": 0})
    late = [a for a in without.alarms if a["kind"] == "process"]
    assert all(a["output"] == o and (o, a["input"]) in model.channels() and a["start_s"] - t0 > starts[0]
               for a in late)


def test_detector_file_and_stream_with_absent_channels(tmp_path, coupling_run):
    _, _, model, data = coupling_run
    detector = Detector.train(model, data, 8 * 3600, "mimo")
    path = tmp_path / "detector.json"
    detector.save(path)
    doc = json.loads(path.read_text())
    assert doc["config"]["absent_channels"] == 2
    again = Detector.load(path)
    batch = detector.monitor(data)
    np.testing.assert_array_equal(again.monitor(data).scores, batch.scores)
    time_s = data["time"].to_numpy()
    u, y = data[list(model.inputs)].to_numpy(), data[list(model.outputs)].to_numpy()
    windows = StreamingDetector(again).push_block(time_s, u, y)
    np.testing.assert_array_equal(np.array([w.scores for w in windows]), batch.scores)


def test_a_channel_written_as_zero_is_an_absent_one(coupling_run):
    """A model file may write a channel it means to leave out as gain 0: the detector takes it
    as absent (a zero impulse response sizes no FIR features and its gain direction spans
    nothing; "nominal transfer function is zero: give fir_length" before)."""
    _, _, model, data = coupling_run
    i, inputs = _absent_output(model)
    (j,) = [j for j in inputs if (model.outputs[i], model.inputs[j]) not in model.channels()]
    process = model.process_dict()
    process[model.outputs[i]][model.inputs[j]] = mpmpp.TransferFunction([0.0], [1.0, -0.5], 3)
    zero = mpmpp.Model(model.name, model.sample_time_s, model.inputs, model.outputs, process, model.noise_dict())
    config = make_config("mimo", model)
    assert _core.WindowFeatures(zero, config).channels == _core.WindowFeatures(model, config).channels
    n = config.window_samples(model.sample_time_s)
    y, u = data[model.outputs[i]].to_numpy()[:n], data[list(model.inputs)].to_numpy()[:n]
    for got, expected in zip(_core.residual_regression(zero, i, inputs, config, y, u),
                             _core.residual_regression(model, i, inputs, config, y, u)):
        np.testing.assert_equal(got, expected)
    paper = make_config("paper_mimo", model)
    assert _core.WindowFeatures(zero, paper).channels == _core.WindowFeatures(model, paper).channels
