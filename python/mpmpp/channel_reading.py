"""A fitted channel read as an engineer states it (docs/identify.md "Method", "Verdicts and
guards"): gain, time constant and dead time with their uncertainty (the delta method on the joint
covariance, the dead time's profile interval), and whether the channel has an effect at the level
the dead-time search calls for."""
from __future__ import annotations

import math
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from .process_class import ProcessClass
from .structure_search import Candidate, channel_params


Z95 = 1.959963984540054
CHI2_1_95 = 3.841458820694124    # 95 % quantile of chi-square(1): profile-likelihood interval
SIGN_FLIP_Z = 5.0                # "overwhelming evidence" for a gain against the controller's action


@dataclass
class ChannelSummary:
    output: str
    input: str
    gain: float
    gain_sd: float
    time_constant_s: float
    time_constant_sd: float
    dead_time_s: float
    dead_time_ci95: tuple[float, float]
    delay_samples: int
    numerator_length: int
    significant: bool                   # |gain| / gain_sd >= significance_z(dead times searched)
    integrating: bool = False           # gain is then the rate gain (output units per s per input unit)
    effect: bool = False                # the numerator is not 0 at the search-corrected level (``_has_effect``)
    unexcited: bool = False             # the input is the output's controller law and nothing else moves it

    @property
    def kept(self) -> bool:
        """In the model: a gain firm at the search-corrected level, or an effect (``_has_effect``)
        whose gain is distinguishable from 0 at 95 %."""
        return bool(self.significant or (self.effect and abs(self.gain) >= Z95 * self.gain_sd))

    @property
    def uncertain(self) -> bool:
        """Usable but loosely determined: sd(K) above 25 % of |K|, sd(tau) above 50 % of tau, or
        an input that only the controller moved (``unexcited``: then sd(K) is no guide)."""
        return bool(self.gain_sd > 0.25 * abs(self.gain) or self.unexcited
                    or (self.time_constant_s > 0 and not self.time_constant_sd <= 0.5 * self.time_constant_s))

    @property
    def dead_time_sd(self) -> float:
        """The profile interval's half width / 1.96 (its normal-equivalent spread)."""
        return (self.dead_time_ci95[1] - self.dead_time_ci95[0]) / (2 * Z95)

    def describe(self) -> str:
        if self.integrating:
            dynamics = (f"integrating, rate gain {self.gain:.4g} +- {self.gain_sd:.2g} per s, "
                        + (f"lag {self.time_constant_s:.4g} +- {self.time_constant_sd:.2g} s, "
                           if self.time_constant_s > 0 else ""))
        else:
            dynamics = (f"gain {self.gain:.4g} +- {self.gain_sd:.2g}, "
                        f"time constant {self.time_constant_s:.4g} +- {self.time_constant_sd:.2g} s, ")
        return (f"{self.output} <- {self.input}: {dynamics}"
                f"dead time {self.dead_time_s:.4g} s (95 % {self.dead_time_ci95[0]:.4g}-"
                f"{self.dead_time_ci95[1]:.4g} s)"
                + ("" if self.kept else ", NOT significant: left out")
                + (", UNCERTAIN: excite the loop (e.g. setpoint steps) for a firmer model"
                   if self.kept and self.uncertain else "")
                + (f" ({self.input} follows the controller exactly and nothing else moves it: such a "
                   "record does not determine the process, and the gain may be far off)"
                   if self.kept and self.unexcited else ""))


def significance_z(dead_times: int) -> float:
    """|K| / sd(K) a gain needs to count as an effect at 5 %: the best of ``dead_times`` searched
    delays is the largest of that many chances, hence the Bonferroni level 0.05 / dead_times."""
    return NormalDist().inv_cdf(1.0 - 0.025 / max(dead_times, 1))


def summarise(out, inp, c: Candidate, j: int, profile, ts, z_effect, cls: ProcessClass) -> ChannelSummary:
    b, f = channel_params(c, j)
    gain, tau, dead = cls.reading(b, f, c.delays[j], ts)
    k = sum(nb + c.nf for nb in c.nb[:j])
    nb = c.nb[j]
    idx = slice(k, k + nb + c.nf)
    cov = c.covariance[idx, idx]
    p = np.r_[b, f[1:]]

    def value(q, which):
        return cls.reading(q[:nb], np.r_[1.0, q[nb:]], c.delays[j], ts)[which]

    gain_sd = _delta_sd(lambda q: value(q, 0), p, cov)
    tau_sd = _delta_sd(lambda q: value(q, 1), p, cov) if tau > 0 else float("nan")
    lo, hi = _profile_interval({s: v for (jj, s), v in profile.items() if jj == j}, c.rows)
    return ChannelSummary(out, inp, float(gain), float(gain_sd), float(tau), float(tau_sd), float(dead),
                          (float(lo * ts), float(hi * ts)), int(c.delays[j]), int(c.nb[j]),
                          bool(abs(gain) >= z_effect * gain_sd), cls.integrating,
                          _has_effect(b, cov[:nb, :nb], z_effect))


def _has_effect(b: np.ndarray, cov_b: np.ndarray, z_effect: float) -> bool:
    """Whether the channel moves the output at all: the Wald test of b = 0 (G = 0 exactly when its
    numerator is 0) at the search-corrected level of ``significance_z``, chi-square with one
    degree of freedom per numerator term. The gain K = B(1) / F(1) is then tested on its own at
    95 %: once the search has found an effect, its steady state is one question, not one per
    dead time. Testing K alone at the search-corrected level refused sticking flow valves whose
    numerator was determined beyond doubt (Wald 120-240 against a threshold of 14) while the
    gain, traded off against a slow pole, was 2-3 standard deviations from 0."""
    try:
        wald = float(b @ np.linalg.solve(cov_b, b))
    except np.linalg.LinAlgError:
        return False
    return _chi2_sf(wald, len(b)) <= 2.0 * (1.0 - NormalDist().cdf(z_effect))


def _chi2_sf(x: float, dof: int) -> float:
    """P(chi-square(dof) > x), exact for integer dof: erfc for one degree of freedom, exp for two,
    then sf(x; k + 2) = sf(x; k) + (x/2)^(k/2) e^(-x/2) / Gamma(k/2 + 1)."""
    if x <= 0:
        return 1.0
    k, sf = (1, math.erfc(math.sqrt(x / 2.0))) if dof % 2 else (2, math.exp(-x / 2.0))
    while k < dof:
        sf += math.exp((k / 2.0) * math.log(x / 2.0) - x / 2.0 - math.lgamma(k / 2.0 + 1.0))
        k += 2
    return sf


def _profile_interval(cost_at: dict, rows: int) -> tuple[float, float]:
    """95 % likelihood-ratio interval of the dead time (samples) from its profile: the dead times
    with n log(V / V_best) <= chi2_1(95 %), widened to the nearest searched dead time outside
    on each side (the profile is known only at the searched points; the boundary lies between)."""
    points = sorted(cost_at)
    best = min(cost_at.values())
    inside = [i for i, s in enumerate(points) if rows * np.log(cost_at[s] / best) <= CHI2_1_95]
    return points[max(inside[0] - 1, 0)], points[min(inside[-1] + 1, len(points) - 1)]


def _delta_sd(fn, p, cov) -> float:
    """sqrt(g' C g) with g the central-difference gradient of fn at p."""
    g = np.empty(len(p))
    for i in range(len(p)):
        h = 1e-6 * max(abs(p[i]), 1e-3)
        up, down = p.copy(), p.copy()
        up[i] += h
        down[i] -= h
        try:
            g[i] = (fn(up) - fn(down)) / (2 * h)
        except TypeError:  # fn left the FOPTD form within h: the spread is not defined
            return float("nan")
    return float(np.sqrt(max(g @ cov @ g, 0.0)))


def against_controller(chans, action) -> bool:
    """A single loop's gain of the sign opposite to the controller's action without overwhelming
    evidence (|K| / sd < SIGN_FLIP_Z): a stable loop needs the controller's sign."""
    if not action or len(chans) != 1:
        return False
    c = chans[0]
    return bool(np.sign(c.gain) != action and abs(c.gain) < SIGN_FLIP_Z * c.gain_sd)
