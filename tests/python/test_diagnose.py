"""diagnose / update on the example cases (examples/) and on a NumPy closed loop; C++ scans vs
brute-force NumPy."""
import json

import numpy as np
import pytest

import mpmpp
from mpmpp import _core
from mpmpp.diagnose import PROCESS_EFFECTS, diagnose, process
from mpmpp.update import update

import closed_loop_case as loop
from example_cases import CASES, NOISE_CHANGE, load_case


# ---- C++ kernels against brute force -------------------------------------------------------

def test_scan_onset_matches_brute_force():
    rng = np.random.default_rng(0)
    n = 600
    psi = rng.standard_normal(n)
    r_without = np.where(np.arange(n) >= 350, 0.8 * psi, 0.0) + rng.standard_normal(n)
    r = r_without - 0.3 * psi           # a nominal channel of scale 0.3 was removed
    weight = (rng.random(n) > 0.1).astype(float)
    fit = _core.scan_onset(r, r_without, psi, weight, 50, 5)
    best = None
    for k in [0, *range(50, n - 50 + 1, 5)]:
        w = weight[k:]
        theta = np.sum(w * r_without[k:] * psi[k:]) / np.sum(w * psi[k:] ** 2)
        stat = np.sum(w * r[k:] ** 2) - np.sum(w * (r_without[k:] - theta * psi[k:]) ** 2)
        if best is None or stat > best[0]:
            best = (stat, k, theta)
    assert fit.onset == best[1]
    assert fit.statistic == pytest.approx(best[0], rel=1e-10)
    assert fit.theta == pytest.approx(best[2], rel=1e-10)
    assert abs(fit.onset - 350) <= 25


def test_split_ar_and_fit_ar_match_numpy():
    rng = np.random.default_rng(1)
    e = rng.standard_normal(3000)
    e[1800:] = np.convolve(e[1800:], [1.0, 0.9])[: 1200] * 1.5
    order = 2

    def ar_var(x_rows):
        lag = np.column_stack([e[x_rows - 1], e[x_rows - 2]])
        coef, *_ = np.linalg.lstsq(lag, e[x_rows], rcond=None)
        return np.mean((e[x_rows] - lag @ coef) ** 2), coef

    split = _core.split_ar(e, order, 300, 10)
    rows = np.arange(order, 3000)
    v_all, _ = ar_var(rows)
    best = max(((len(rows) * np.log(v_all) - (k - order) * np.log(ar_var(np.arange(order, k))[0])
                 - (3000 - k) * np.log(ar_var(np.arange(k, 3000))[0]), k)
                for k in range(order + 300, 3000 - 300 + 1, 10)))
    assert split.onset == best[1]
    assert split.statistic == pytest.approx(best[0], rel=1e-8)
    _, coef = ar_var(np.arange(1000, 1800))
    np.testing.assert_allclose(_core.fit_ar(e, order, 1000, 1800), np.r_[1.0, -coef], atol=1e-10)


# ---- the example cases --------------------------------------------------------------------

@pytest.mark.parametrize("case", CASES)
def test_top_finding_matches_the_hidden_effect(case):
    model, data, truth = load_case(case)
    res = diagnose(model, data)
    assert res.findings, "no finding"
    top = res.findings[0]
    assert top.effect == truth["effect"]
    assert top.output == truth["output"]
    assert top.input == truth.get("input")
    assert abs(top.onset_s - truth["onset_s"]) <= 3600
    assert top.error_after < top.error_before
    d = res.to_dict()
    json.dumps(d)
    assert set(d) == {"findings"}
    assert {"id", "effect", "output", "onset_s", "confidence", "estimate", "error_before", "error_after",
            "explanation"} <= set(d["findings"][0])
    if top.effect in ("gain", "missing_coupling"):   # a channel change: its onset set, the onset in it
        assert top.onset_earliest_s <= top.onset_s <= top.onset_latest_s
        assert d["findings"][0]["onset_earliest_s"] == pytest.approx(top.onset_earliest_s)
        assert ("fits as well" in top.explanation) == (top.onset_latest_s - top.onset_earliest_s > process.ONSET_SET_SHOWN_S)
        assert "t=" not in top.explanation.split("(any onset")[-1]   # only the onset is a point in time
        assert " 0 s " not in top.explanation
    else:
        assert "onset_earliest_s" not in d["findings"][0]
    if case == NOISE_CHANGE:
        assert not [f for f in res.findings if f.effect in PROCESS_EFFECTS]
    if truth["effect"] == "gain":
        lo, hi = top.estimate["ci95"]
        assert lo <= truth["ratio"] <= hi or abs(top.estimate["gain_ratio"] - truth["ratio"]) < 0.15
    if truth["effect"] == "missing_coupling":
        assert abs(top.estimate["gain"] - truth["gain"]) < 0.15 * abs(truth["gain"])


@pytest.mark.parametrize("case", CASES)
def test_update_lowers_the_held_out_error_and_writes_a_valid_model(case, tmp_path):
    model, data, _ = load_case(case)
    res = update(model, data, "F1")
    assert all(e.error_after < e.error_before for e in res.errors)
    path = tmp_path / "new.json"
    res.save(path)
    again = mpmpp.load_model(path)
    assert again.outputs == model.outputs


# ---- a NumPy closed loop: no invented findings, and a gain change found ----------------------

def test_no_finding_when_the_data_agree_with_the_model():
    data = loop.simulate(n=8000, seed=11)
    assert diagnose(loop.model(), data).findings == []


def test_gain_change_in_numpy_loop():
    data = loop.simulate(n=8000, seed=12, onset=4000, gain=1.8)
    res = diagnose(loop.model(), data)
    top = res.findings[0]
    assert (top.effect, top.input) == ("gain", "u")
    assert abs(top.onset_s - 4000 * loop.TS) <= 3600
    assert abs(top.estimate["gain_ratio"] - 1.8) < 0.2


def test_unmodeled_column_in_numpy_loop():
    data = loop.simulate(n=8000, seed=13, w_gain=1.0)
    top = diagnose(loop.model(), data).findings[0]
    assert (top.effect, top.input) == ("unmodeled_input", "w")


def test_bad_arguments():
    data = loop.simulate(n=8000, seed=14)
    with pytest.raises(ValueError, match="train-end"):
        diagnose(loop.model(), data, train_end_s=-5)
    with pytest.raises(ValueError, match="--apply"):
        update(loop.model(), data, "F9")
