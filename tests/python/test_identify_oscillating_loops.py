"""``model_from_data`` on PI loops that oscillate by themselves (the stiction study's tuning flow
loop, studies/stiction_benchmark.py: K = 1, tau = 15 s, the process acting from the next sample,
i.e. no dead time after the hold; 751 rows at 10 s): a sticking valve's limit cycle is
excitation, so the loop is identified; a record whose output ignores the input is still refused.
The numerator's Wald test is checked against SciPy's chi-square distribution and a plain NumPy
form, the class choice against the controller's action on constructed fits."""
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2, norm

from mpmpp.identify import model_from_data
from mpmpp.channel_reading import ChannelSummary, _chi2_sf, _has_effect, significance_z
from mpmpp.class_choice import ClassFit, choose_class
from mpmpp.model_identification import NotIdentified
from mpmpp.process_class import INTEGRATING_LAG, SELF_REGULATING

import stiction_benchmark as sb

FLOW = next(d for d in sb.TUNING if d.name == "flow")


def flow_record(case, seed, s):
    rec = sb.make_record("tuning", FLOW, case, s, 0.5 * s, seed)
    return pd.DataFrame({"time": 10.0 * np.arange(len(rec["op"])), "OP": rec["op"], "PV": rec["pv"] + 20.0,
                         "PV_sp": rec["sp"] + 20.0})


def test_sticking_flow_valve_is_identified_not_refused_for_lack_of_excitation():
    """Seed 7001, S = 1.5 % OP: the numerator is determined beyond doubt while the gain, traded
    off against a slow pole, is 2.3 sd from 0 (refused at the search-corrected level alone)."""
    r = model_from_data(flow_record("stiction", 7001, 1.5), ["OP"], ["PV"])
    c, = r.channels
    assert r.outputs[0].process_class == SELF_REGULATING.name
    assert c.effect and c.kept and not c.significant and c.uncertain
    assert c.gain > 0 and abs(c.gain - FLOW.process.b[0] / (1 + FLOW.process.a[1])) < 2 * c.gain_sd
    assert c.dead_time_s <= 10.0                              # truth 0 s: within a sample
    assert r.model.process("PV", "OP") is not None


def test_output_that_ignores_the_input_is_still_refused():
    data = flow_record("stiction", 7001, 1.5)
    rng = np.random.default_rng(3)
    data["OP"] = 50 + np.cumsum(rng.standard_normal(len(data))) * 0.3   # moves, PV ignores it
    with pytest.raises(NotIdentified, match="no input explains 'PV'"):
        model_from_data(data, ["OP"], ["PV"])


@pytest.mark.parametrize("dof", [1, 2, 3, 4, 5])
def test_chi2_survival_is_scipys(dof):
    x = np.array([1e-3, 0.5, 3.0, 11.2, 14.2, 40.0])
    assert np.allclose([_chi2_sf(v, dof) for v in x], chi2.sf(x, dof), rtol=1e-12, atol=1e-300)


def test_numerator_wald_test_matches_a_numpy_form():
    z = significance_z(61)
    level = 2 * norm.sf(z)
    cov = np.array([[0.04, 0.01], [0.01, 0.09]])
    for b in (np.array([0.5, 0.6]), np.array([0.3, -0.2]), np.array([0.05, 0.02])):
        wald = b @ np.linalg.inv(cov) @ b
        assert _has_effect(b, cov, z) == (chi2.sf(wald, 2) <= level)
    assert _has_effect(np.array([1.0]), np.array([[1.0 / z**2 * 0.99]]), z)      # Wald just above z^2
    assert not _has_effect(np.array([1.0]), np.array([[1.0 / z**2 * 1.01]]), z)


def test_a_fit_against_the_controllers_action_does_not_replace_first_order():
    """A wrong-signed integrator with a lag and a dead time (the feedback path fitted as the
    process) would take first order's place by the dead-time rule; with the controller's action
    known it identifies nothing, so first order stays and the verdict speaks for it."""
    def fit(cls, bic, gain, significant, dead=80.0, action=1):
        c = ChannelSummary("PV", "OP", gain, abs(gain) / 4.5, 60.0, 5.0, dead, (0.0, 90.0), 9, 1, significant)
        return ClassFit(cls, SimpleNamespace(bic=bic), [c], action)

    default = fit(SELF_REGULATING, 0.0, 2.7, False, dead=5.0)
    assert choose_class([default, fit(INTEGRATING_LAG, 219.0, -0.005, True)], 7500.0, 10.0)[0] is SELF_REGULATING
    # the same fit with no controller action seen: nothing speaks against it
    assert choose_class([fit(SELF_REGULATING, 0.0, 2.7, False, dead=5.0, action=0),
                         fit(INTEGRATING_LAG, 219.0, -0.005, True, action=0)], 7500.0, 10.0)[0] is INTEGRATING_LAG
