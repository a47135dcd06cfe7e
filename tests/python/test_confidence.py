"""The confidence calibration map (diagnose/confidence.py): features, the logistic fit against
scikit-learn's probabilities, the shipped map fitted on tuning families only."""
import math

import numpy as np
import pytest
from sklearn.linear_model import LogisticRegression

from mpmpp import families as fam
from mpmpp.diagnose import confidence as conf


def finding(score, before, after, pb, pa, effect="gain", actuator=None):
    return {"effect": effect, "score": score, "error_before": before, "error_after": after,
            "process_error_before": pb, "process_error_after": pa, "actuator_score": actuator}


def test_features():
    kinds = conf.FEATURES[6:]

    def kind(name):
        return [1.0 if f == f"effect_{name}" else 0.0 for f in kinds]

    x = conf.features(finding(99.0, 1.0, 0.9, 0.5, 0.1, actuator=9.0))
    assert x == pytest.approx([math.log(100.0), 0.1, 0.8, math.log(0.5), math.log(10.0 / 100.0), 0.0, *kind("gain")])
    # unknown process errors: no fall, the smallest share; a disturbance effect: no actuator rival
    y = conf.features(finding(-3.0, 1.0, 0.5, None, None, effect="noise_change", actuator=50.0))
    assert y == pytest.approx([0.0, 0.5, 0.0, math.log(1e-3), 0.0, 0.0, *kind("noise_change")])
    # an unmodelled measured input is the same search as a missing coupling
    z = conf.features(finding(9.0, 1.0, 0.9, 0.5, 0.4, effect="unmodeled_input"))
    assert z[6:] == pytest.approx(kind("missing_coupling"))


def test_actuator_rival():
    """log(1 + actuator score) - log(1 + the finding's score), scores floored at 0, for gain,
    time-constant and dead-time findings; 0 when the search did not run on the input."""
    rival = conf.FEATURES.index("actuator_rival")
    for effect in ("gain", "time_constant", "delay"):
        assert conf.features(finding(63.0, 1.0, 0.9, 0.5, 0.1, effect, actuator=-4.0))[rival] == pytest.approx(-math.log(64.0))
        assert conf.features(finding(3.0, 1.0, 0.9, 0.5, 0.1, effect, actuator=15.0))[rival] == pytest.approx(math.log(4.0))
        assert conf.features(finding(3.0, 1.0, 0.9, 0.5, 0.1, effect))[rival] == 0.0
    # the shipped map: a gain the actuator explains as well is less confident than one it does not
    contested = conf.calibrated_confidence(finding(200.0, 1.0, 0.9, 0.5, 0.1, actuator=200.0))
    clear = conf.calibrated_confidence(finding(200.0, 1.0, 0.9, 0.5, 0.1, actuator=-5.0))
    assert contested < clear


def test_actuator_close():
    """1 when the actuator search scores about as well as a gain, time-constant or dead-time
    finding (the rival above ACTUATOR_CLOSE), 0 below, without a search and for other effects;
    on the shipped map a tie at a score of 12,000 (a valve pinned beyond its band against a gain
    cut to a quarter, tuning pi_siso seed 9) is no confident finding."""
    close = conf.FEATURES.index("actuator_close")
    for effect in ("gain", "time_constant", "delay"):
        assert conf.features(finding(12000.0, 1.0, 0.9, 0.5, 0.1, effect, actuator=11900.0))[close] == 1.0
        assert conf.features(finding(12000.0, 1.0, 0.9, 0.5, 0.1, effect, actuator=9000.0))[close] == 0.0
        assert conf.features(finding(12000.0, 1.0, 0.9, 0.5, 0.1, effect))[close] == 0.0
    assert conf.features(finding(12000.0, 1.0, 0.9, 0.5, 0.1, "output_drift", actuator=12000.0))[close] == 0.0
    tie = conf.calibrated_confidence(finding(12000.0, 0.05, 0.049, 0.005, 0.001, actuator=11900.0))
    assert tie < 0.9 < conf.calibrated_confidence(finding(12000.0, 0.05, 0.049, 0.005, 0.001, actuator=100.0))


def test_fitted_map_reproduces_sklearn_probabilities():
    rng = np.random.default_rng(0)
    fs, labels = [], []
    for _ in range(300):
        score = float(rng.exponential(50))
        fall = float(rng.uniform(0, 0.9))
        fs.append(finding(score, 1.0, 1.0 - 0.1 * fall, 0.5, 0.5 * (1 - fall)))
        labels.append(bool(rng.uniform() < 1 / (1 + math.exp(-(4 * fall - 1.5)))))
    cal = conf.fit_map(fs, labels)
    x = np.array([conf.features(f) for f in fs])
    mean, scale = x.mean(axis=0), x.std(axis=0)
    scale[scale == 0] = 1.0
    ref = LogisticRegression(C=1.0, tol=1e-12, max_iter=10000).fit((x - mean) / scale, labels)
    want = ref.predict_proba((x - mean) / scale)[:, 1]
    got = np.array([conf.probability(cal, f) for f in fs])
    assert got == pytest.approx(want, abs=1e-9)
    # the process-part fall carries the signal here: its coefficient is positive
    assert cal["coef"][conf.FEATURES.index("process_fall")] > 0
    with pytest.raises(ValueError, match="right and wrong"):
        conf.fit_map(fs[:3], [True] * 3)


def test_shipped_map_was_fitted_on_tuning_families_only():
    cal = conf.shipped_map()
    assert cal is not None and cal["features"] == list(conf.FEATURES)
    tuning = {f.name for f in fam.FAMILIES if f.split == fam.TUNING}
    assert set(cal["fitted_on"]["families"]) <= tuning
    assert max(cal["fitted_on"]["seeds"]) < 100   # docs/families.md: seeds 0-99 are for choosing
    p = conf.calibrated_confidence(finding(500.0, 1.0, 0.8, 0.6, 0.05))
    q = conf.calibrated_confidence(finding(5.0, 1.0, 0.999, 0.05, 0.049))
    assert 0.0 <= q < p <= 1.0


def test_update_falls_only_raise_confidence():
    """Labels that favour a small one-step fall: an unconstrained fit gives that fall a
    negative weight; the map's is 0, so a finding whose update lowers the error less is never
    the more confident one."""
    rng = np.random.default_rng(1)
    fs, labels = [], []
    for _ in range(400):
        score, one_step, process = float(rng.exponential(50)), float(rng.uniform(0, 0.3)), float(rng.uniform(0, 0.9))
        fs.append(finding(score, 1.0, 1.0 - one_step, 0.5, 0.5 * (1 - process)))
        labels.append(bool(rng.uniform() < 1 / (1 + math.exp(-(3 * process - 10 * one_step)))))
    x = np.array([conf.features(f) for f in fs])
    scale = np.where(x.std(axis=0) > 0, x.std(axis=0), 1.0)
    free = LogisticRegression(C=1.0, tol=1e-12, max_iter=10000).fit((x - x.mean(axis=0)) / scale, labels)
    assert free.coef_[0][conf.FEATURES.index("one_step_fall")] < 0
    cal = conf.fit_map(fs, labels)
    assert cal["coef"][conf.FEATURES.index("one_step_fall")] == 0.0
    assert cal["coef"][conf.FEATURES.index("process_fall")] > 0
    barely = conf.probability(cal, finding(200.0, 1.0, 0.999, 0.5, 0.49))
    clearly = conf.probability(cal, finding(200.0, 1.0, 0.8, 0.5, 0.1))
    assert barely < clearly
