"""An independent NumPy/SciPy + scikit-learn implementation of the paper's detector.

The named peer of bench/bench_detect.py and a tuning sandbox: the same algorithm as
mpmpp's C++ core (moving windows, ARX with the R_reg rule, A-filtered FOPTD output-error
fit, FIR expansion, resampling, standardisation, one-class SVM with an outlier-fraction
offset, indicator eq. 23), written plainly for reading, not speed.
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter
from sklearn.svm import OneClassSVM


def arx(y, us, delays, na, nb, delta=1e-4):
    """MISO ARX A(q) y = sum_j B_j(q) q^-d_j u_j + e; returns a (a_1..a_na), list of b_j."""
    N = len(y)
    start = max([na] + [d + nb for d in delays])
    cols = [-y[start - k:N - k] for k in range(1, na + 1)]
    for u, d in zip(us, delays):
        cols += [u[start - d - k:N - d - k] for k in range(0, nb + 1)]
    Phi = np.column_stack(cols)
    Y = y[start:]
    n = len(Y)
    R = Phi.T @ Phi / n
    if np.linalg.norm(np.linalg.inv(R), 2) >= 2 / delta:
        R = R + delta / 2 * np.eye(R.shape[0])
    theta = np.linalg.solve(R, Phi.T @ Y / n)
    a = theta[:na]
    bs = np.split(theta[na:], len(us))
    return a, bs


def oe_foptd(yf, ufs, delays):
    """Joint MISO FOPTD OE fit yf = sum_j b_j q^-d_j / (1 + f_j q^-1) uf_j; returns [(b, f)]."""
    def sim(p):
        out = np.zeros_like(yf)
        for j, (u, d) in enumerate(zip(ufs, delays)):
            b, f = p[2 * j], p[2 * j + 1]
            ud = np.concatenate([np.zeros(d), u[:len(u) - d]])
            out += lfilter([b], [1.0, f], ud)
        return out
    # equation-error start: yf(t) = -f yf(t-1) + b uf(t-d), per input jointly
    N = len(yf)
    s = max(delays) + 1
    Phi = [-yf[s - 1:N - 1]] + [u[s - d:N - d] for u, d in zip(ufs, delays)]
    th = np.linalg.lstsq(np.column_stack(Phi), yf[s:], rcond=None)[0]
    f0 = float(np.clip(th[0], -0.99, 0.99))
    p0 = []
    for j in range(len(ufs)):
        p0 += [th[1 + j], f0]
    res = least_squares(lambda p: sim(p) - yf, p0, method="lm")
    return [(res.x[2 * j], res.x[2 * j + 1]) for j in range(len(ufs))]


def fir(b, f, m):
    return b * (-f) ** np.arange(m)


def window_features(y, u, channels, delays, na, nb, fir_len):
    """y: (W, ny), u: (W, nu). channels: dict output -> list of inputs. Returns dict of features."""
    feats = {}
    y = y - y.mean(axis=0)
    u = u - u.mean(axis=0)
    for i, inputs in channels.items():
        us = [u[:, j] for j in inputs]
        ds = [delays[(i, j)] for j in inputs]
        a, _ = arx(y[:, i], us, ds, na, nb)
        A = np.concatenate([[1.0], a])
        yf = lfilter(A, [1.0], y[:, i])
        ufs = [lfilter(A, [1.0], x) for x in us]
        params = oe_foptd(yf, ufs, ds)
        for j, (b, f) in zip(inputs, params):
            feats[("process", i, j)] = fir(b, f, fir_len[(i, j)])
        feats[("noise", i)] = a
    return feats


class ChannelSvm:
    def __init__(self, train_feats, alpha, nu, c, outlier_fraction, n_resampled, rng):
        X = np.asarray(train_feats)
        mu, sd = X.mean(axis=0), X.std(axis=0, ddof=1)
        Z = mu + alpha * sd * rng.standard_normal((n_resampled, X.shape[1]))
        self.mean = Z.mean(axis=0)
        self.scale = Z.std(axis=0) * np.sqrt(X.shape[1])
        self.scale[self.scale == 0] = 1.0
        Zs = (Z - self.mean) / self.scale
        self.svm = OneClassSVM(nu=nu, gamma=1.0 / c, tol=1e-3).fit(Zs)
        s = self.svm.decision_function(Zs)
        self.shift = np.quantile(s, outlier_fraction) if outlier_fraction > 0 else 0.0

    def score(self, x):
        return float(self.svm.decision_function(((np.asarray(x) - self.mean) / self.scale)[None])[0] - self.shift)


def indicator(scores, n_T):
    neg = (np.asarray(scores) < 0).astype(float)
    c = np.convolve(neg, np.ones(n_T))[:len(neg)]
    return c / n_T
