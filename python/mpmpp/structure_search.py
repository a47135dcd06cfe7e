"""The structure search of ``identify`` (docs/identify.md "Method"): per output and process class,
every channel's dead time and numerator length and the ARX (noise) order, each candidate fitted by
ARX-OE (paper Section 3) and refined to the joint prediction-error fit of G and H = 1/A, compared by
BIC on one common sample range."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .identify import arx_oe, oe
from .process_class import ProcessClass
from .stretches import Stretches


# Candidates whose search criterion is this far above the best (n log(V / V_best)) are not
# refined: refinement lowers V, but not by that much; 5 times the 95 % profile threshold.
PRUNE = 5 * 3.841458820694124


class NotIdentified(ValueError):
    """The data do not identify the loop (the message says why)."""


@dataclass
class Candidate:
    bic: float
    cost: float                  # mean squared one-step error over the common range
    a: np.ndarray                # a_1..a_na
    delays: list[int]
    nb: list[int]
    nf: int                      # denominator order of every channel (ProcessClass.nf)
    tf: list                     # TransferFunction per input, in the fitted domain
    theta: np.ndarray            # OE parameters [b_1 f_1 b_2 f_2 ...] per channel
    rows: int                    # length of the common range
    covariance: np.ndarray | None = None  # of [theta, a] (``joint_covariance``), for the chosen one


def output_domain(c: Candidate, cls: ProcessClass):
    """c's channels and noise denominator as the model of y: for an integrating output
    G = G' / (1 - q^-1), and H = 1 / (A (1 - q^-1)) when the disturbance integrates too."""
    if not cls.integrating:
        return list(c.tf), np.r_[1.0, c.a]
    return ([_core.TransferFunction(np.asarray(g.num), np.convolve(g.den, [1.0, -1.0]), g.delay) for g in c.tf],
            np.convolve(np.r_[1.0, c.a], [1.0, -1.0]) if cls.noise_integrates else np.r_[1.0, c.a])


def _integrated(U: np.ndarray, st: Stretches) -> np.ndarray:
    """u / (1 - q^-1) per input (running sums of the deviations from the mean), each stretch's
    mean removed: the level the inflows alone would give, around y's mean in that stretch (what
    flowed in during a gap is unknown)."""
    return st.demeaned(st.cumsum(U))


def differenced(y: np.ndarray, st: Stretches) -> np.ndarray:
    """(1 - q^-1) y with mean removed, on y's rows (each stretch's first is 0 before the mean's
    removal)."""
    dy = st.differenced(y)
    return dy - dy.mean()


def _sweep(y, U, cls: ProcessClass, na, min_delay, max_delay, numerator_lengths, t0, st: Stretches):
    """Coordinate search at noise order na over each channel's (delay, numerator length) by
    ARX-OE: (the BIC-best candidate refined to the joint fit, or None when none could be fitted;
    every candidate fitted as (channel, candidate); the number of fits)."""
    m = U.shape[1]
    delays, nb = [min_delay] * m, [1] * m
    current, tried, count = None, [], 0
    for _round in range(1 if m == 1 else 2):
        for j in range(m):
            for d in range(min_delay, max_delay + 1):
                for k in numerator_lengths:
                    trial_d, trial_nb = list(delays), list(nb)
                    trial_d[j], trial_nb[j] = d, k
                    c = fit_candidate(y, U, na, trial_d, trial_nb, cls, t0, st)
                    count += 1
                    if c is None:
                        continue
                    tried.append((j, c))
                    if current is None or c.bic < current.bic:
                        current = c
            if current is not None:
                delays, nb = list(current.delays), list(current.nb)
    return (None if current is None else refine(y, U, current, cls, t0, st)), tried, count


def search_structure(y, U, cls: ProcessClass, min_delay, max_delay, na_orders, numerator_lengths, t0, pool=None,
                     st: Stretches | None = None):
    """``_sweep`` for every na over the stretches ``st`` (default: the rows are one stretch), in
    cls's domain (y differenced for an integrating output), on
    ``pool``'s threads when given (the ARX-OE fits release the GIL; each sweep is independent, so
    the result does not depend on the threads). The BIC-best na is kept; at that na every
    candidate not clearly worse (PRUNE) is refined too, and the BIC-best refined candidate
    returned with the profile {(channel, dead time in samples): refined cost, inf for pruned ones}
    and the number of candidates fitted."""
    m = U.shape[1]
    st = st or Stretches([len(y)])
    if cls.integrating and cls.noise_integrates:
        # mean removed: a constant inflow imbalance (OP's mean is not the balancing flow)
        y = differenced(y, st)
    elif cls.integrating:
        y, U = st.demeaned(y), _integrated(U, st)
    sweeps = list((pool.map if pool else map)(
        lambda na: _sweep(y, U, cls, na, min_delay, max_delay, numerator_lengths, t0, st), na_orders))
    finalists = [s[0] for s in sweeps if s[0] is not None]
    tried = {na: s[1] for na, s in zip(na_orders, sweeps)}
    count = sum(s[2] for s in sweeps)
    if not finalists:
        raise NotIdentified("not identified: no candidate model could be fitted (data not informative)")
    best = min(finalists, key=lambda c: c.bic)
    profile = {}
    for j, c in tried[len(best.a)]:
        if c.rows * np.log(c.cost / best.cost) <= PRUNE:
            c = refine(y, U, c, cls, t0, st)
            if c.bic < best.bic:
                best = c
            cost = c.cost
        else:
            cost = np.inf
        where = (j, _dead_time_samples(c, j, cls))
        profile[where] = min(profile.get(where, np.inf), cost)
    for j in range(m):
        where = (j, _dead_time_samples(best, j, cls))
        profile[where] = min(profile.get(where, np.inf), best.cost)
    best.covariance = joint_covariance(y, U, best, st)
    return best, profile, count


def joint_covariance(y, U, c: Candidate, st: Stretches | None = None) -> np.ndarray:
    """sigma^2 (J'J)^-1 of all parameters [b_1 f_1 ... b_m f_m, a_1..a_na] of the joint fit,
    eps = A (y - sum_j B_j / F_j q^-d_j u_j) over t >= na. Under feedback the estimates of G
    and H are correlated, so the OE covariance (A held fixed) would understate G's spread.
    Sensitivities: d eps / d b_jk = -A q^-k w_j with w_j = q^-d_j u_j / F_j,
    d eps / d f_j1 = A q^-1 x_j / F_j with x_j = G_j u_j, d eps / d a_i = q^-i v, v = y - sum x_j.
    Over the stretches ``st`` (default: one), each from rest."""
    st = st or Stretches([len(y)])
    na = len(c.a)
    A = _core.TransferFunction(np.r_[1.0, c.a], np.ones(1), 0)
    x = [st.filter(g, U[:, j]) for j, g in enumerate(c.tf)]
    v = y - sum(x)
    cols = []
    for j, g in enumerate(c.tf):
        inv_f = _core.TransferFunction(np.ones(1), np.asarray(g.den), 0)
        w = st.filter(_core.TransferFunction(np.ones(1), np.asarray(g.den), g.delay), U[:, j])
        aw = st.filter(A, w)
        cols += [-st.lag(aw, k) for k in range(c.nb[j])]
        if c.nf:
            cols.append(st.lag(st.filter(A, st.filter(inv_f, x[j])), 1))
    cols += [st.lag(v, i) for i in range(1, na + 1)]
    rows = st.after(na)
    J = np.column_stack(cols)[rows]
    eps = st.filter(A, v)[rows]
    sigma2 = eps @ eps / max(len(eps) - J.shape[1], 1)
    return sigma2 * np.linalg.pinv(J.T @ J)


def fit_candidate(y, U, na, delays, nb, cls, t0, st: Stretches | None = None):
    """One candidate by ARX-OE over the stretches ``st`` (default: one), or None when it is not
    informative or not of cls's form."""
    st = st or Stretches([len(y)])
    try:
        r = arx_oe(y, U, na, na + 1, delays, structure="oe", oe_nb=nb, oe_nf=cls.nf, fir_length=1,
                   detrend="none", stretch_starts=st.starts)
    except RuntimeError:
        return None
    return _candidate(y, U, np.asarray(r.noise), delays, nb, cls, r.oe, t0, st)


def _candidate(y, U, a, delays, nb, cls, oe_result, t0, st: Stretches):
    tf = []
    for j, d in enumerate(delays):
        b, f = np.asarray(oe_result.b[j]), np.asarray(oe_result.f[j])
        if cls.reading(b, f, d, 1.0) is None:
            return None
        tf.append(_core.TransferFunction(b, f, d))
    inverse_noise = _core.TransferFunction(np.r_[1.0, a], np.ones(1), 0)
    e = y - sum(st.filter(g, U[:, j]) for j, g in enumerate(tf))
    e = st.filter(inverse_noise, e)[st.after(t0)]
    cost = float(np.mean(e**2))
    # per channel K, theta (and tau): the dead time is one continuous parameter whether it falls
    # on a sample (one numerator term) or between two (two terms, docs/formats.md's ZOH form);
    # counting b1 as an extra parameter made BIC round a fractional dead time down to the sample
    # and tau absorb the rest
    n, k = len(e), len(a) + cls.parameters * len(nb)
    return Candidate(n * np.log(cost) + k * np.log(n), cost, a, list(delays), list(nb), cls.nf, tf,
                     np.asarray(oe_result.theta), n)


def refine(y, U, c: Candidate, cls, t0, st: Stretches | None = None, max_iterations=200, tolerance=1e-12):
    """The joint prediction-error fit of G and H = 1/A for c's structure, by alternating the two
    least-squares problems it splits into: A given G (an AR fit of v = y - G u) and G given A
    (the OE fit on A-filtered data), both over t >= na. Each step lowers sum (A (y - G u))^2,
    so the ARX step's A, biased when the ARX orders are low, no longer biases G. Stops when a
    step lowers that sum by less than ``tolerance`` (relative) or fails. Over the stretches
    ``st`` (default: one), each from rest."""
    st = st or Stretches([len(y)])
    na = len(c.a)
    rows = st.after(na)
    best, level = c, np.inf
    for _ in range(max_iterations):
        v = y - sum(st.filter(g, U[:, j]) for j, g in enumerate(best.tf))
        lagged = np.column_stack([-st.lag(v, i + 1) for i in range(na)])
        a = np.linalg.lstsq(lagged[rows], v[rows], rcond=None)[0]
        A = _core.TransferFunction(np.r_[1.0, a], np.ones(1), 0)
        yf = st.filter(A, y)
        uf = st.filter_columns(A, U)
        try:
            r = oe(yf, uf, best.delays, structure="oe", nb=best.nb, nf=cls.nf, skip=na,
                   stretch_starts=st.starts)
        except RuntimeError:
            return best
        trial = _candidate(y, U, a, best.delays, best.nb, cls, r, t0, st)
        if trial is None or not r.cost < level:
            return best
        best, done = trial, r.cost > level * (1 - tolerance)
        level = r.cost
        if done:
            break
    return best


def _dead_time_samples(c: Candidate, j: int, cls: ProcessClass) -> float:
    b, f = channel_params(c, j)
    return cls.reading(b, f, c.delays[j], 1.0)[2]


def channel_params(c: Candidate, j: int):
    k = sum(nb + c.nf for nb in c.nb[:j])
    nb = c.nb[j]
    return c.theta[k:k + nb], np.r_[1.0, c.theta[k + nb:k + nb + c.nf]]
