"""A plain NumPy/SciPy version of the studies' evidence statistic (diagnosis_study.change_evidence):
the drop of the squared one-step error H^-1 (y - G u) after the onset when the channel G0 is
replaced by G1, over the nominal error's variance before it, on a SISO record's deviations from
its means."""
import numpy as np
from scipy.signal import lfilter


def reference_evidence(data, output: str, input_: str, g0, g1, h, onset_sample: int,
                       limits: tuple | None = None) -> float:
    """``limits`` (lower, upper): the change is instead a saturation of the input from the onset
    on (G1 = G0), the plant seeing the input clipped there."""
    y = data[output].to_numpy() - data[output].mean()
    u_abs = data[input_].to_numpy()
    u = u_abs - u_abs.mean()
    u1 = u.copy()
    if limits is not None:
        u1[onset_sample:] = np.clip(u_abs[onset_sample:], *limits) - u_abs.mean()

    def one_step(g, x):
        return lfilter(h.den, h.num, y - lfilter(np.r_[np.zeros(g.delay), g.num], g.den, x))
    e0, e1 = one_step(g0, u), one_step(g1, u1)
    k = onset_sample
    return float(np.sum(e0[k:] ** 2 - e1[k:] ** 2) / np.var(e0[:k]))
