"""Independent NumPy/SciPy implementation of the ARX-OE equations (paper Section 3).

Written from the equations, not from the C++: explicit regressor matrices and
numpy.linalg.lstsq for ARX and FIR, scipy.signal.lfilter for A(q)-filtering and
simulation, scipy.optimize.least_squares on the OE criterion (10). Used by the tests
(equality to 1e-8) and by bench/bench_arx_oe.py (the speed peer).
"""
from __future__ import annotations

import numpy as np
import scipy.optimize as so
import scipy.signal as ss


def arx_regressors(y, u, na, nb, delays):
    """Phi with rows t = t0..N-1: [-y(t-1)..-y(t-na), u_j(t-d_j)..u_j(t-d_j-nb_j+1) ...]."""
    N = len(y)
    t0 = max([na] + [d + b - 1 for b, d in zip(nb, delays)])
    t = np.arange(t0, N)
    cols = [-y[t - k] for k in range(1, na + 1)]
    for j, (b, d) in enumerate(zip(nb, delays)):
        cols += [u[t - d - k, j] for k in range(b)]
    return np.column_stack(cols), y[t0:]


def arx(y, u, na, nb, delays, delta=0.0):
    """Least squares; with delta > 0 the Section 3.1 rule on the regressor-scaled R
    (ridge delta/2 * diag(Phi'Phi) when lambda_min(D^-1/2 Phi'Phi D^-1/2) <= delta/2)."""
    Phi, target = arx_regressors(y, u, na, nb, delays)
    G = Phi.T @ Phi
    d = np.sqrt(np.diag(G))
    lam_min = np.linalg.eigvalsh(G / np.outer(d, d))[0]
    if delta > 0 and lam_min <= delta / 2:
        Phi_aug = np.vstack([Phi, np.diag(np.sqrt(delta / 2) * d)])
        theta = np.linalg.lstsq(Phi_aug, np.r_[target, np.zeros(len(d))], rcond=None)[0]
        regularised = True
    else:
        theta = np.linalg.lstsq(Phi, target, rcond=None)[0]
        regularised = False
    eps = target - Phi @ theta
    return theta, eps @ eps / (len(target) - len(theta)), regularised


def simulate(theta, u, chans):
    """sum_j q^-d_j B_j/F_j u_j with zero initial state; chans = [(nb, nf, d), ...]."""
    yhat = np.zeros(u.shape[0])
    k = 0
    for j, (nb, nf, d) in enumerate(chans):
        b, f = theta[k:k + nb], theta[k + nb:k + nb + nf]
        k += nb + nf
        yhat += ss.lfilter(np.r_[np.zeros(d), b], np.r_[1.0, f], u[:, j])
    return yhat


def oe_jacobian(theta, u, chans, skip):
    """d eps / d theta = -d yhat / d theta via the sensitivity filters."""
    cols = []
    k = 0
    for j, (nb, nf, d) in enumerate(chans):
        b, f = theta[k:k + nb], theta[k + nb:k + nb + nf]
        k += nb + nf
        F = np.r_[1.0, f]
        w = ss.lfilter(np.r_[np.zeros(d), 1.0], F, u[:, j])
        yj = ss.lfilter(np.r_[np.zeros(d), b], F, u[:, j])
        v = ss.lfilter([1.0], F, yj)
        cols += [np.r_[np.zeros(i), w[:len(w) - i]] for i in range(nb)]
        cols += [-np.r_[np.zeros(i), v[:len(v) - i]] for i in range(1, nf + 1)]
    return -np.column_stack(cols)[skip:]


def oe(y, u, chans, theta0, skip=0):
    """least_squares on eps(t) = y(t) - sum_j G_j u_j(t), t >= skip, from theta0."""
    def residual(th):
        return (y - simulate(th, u, chans))[skip:]

    def jac(th):
        return oe_jacobian(th, u, chans, skip)

    x = so.least_squares(residual, theta0, jac=jac, method="lm", xtol=1e-15, ftol=1e-15,
                         gtol=1e-15, max_nfev=2000).x
    # MINPACK stops on its cost-reduction test while b and f (strongly correlated for a
    # slow pole) can still move by ~1e-9; two Gauss-Newton steps polish to the minimum.
    for _ in range(2):
        x = x - np.linalg.lstsq(jac(x), residual(x), rcond=None)[0]
    return x


def prony(g, nb, nf):
    """Kalman/Prony fit of B/F (nb, nf) to an impulse response g (sample 0 after the delay)."""
    L = len(g)
    gz = np.r_[np.zeros(nf), g]  # gz[k + nf] = g[k], zero before 0
    f = np.zeros(nf)
    if nf > 0 and L - nb >= nf:
        M = np.array([[gz[k - i + nf] for i in range(1, nf + 1)] for k in range(nb, L)])
        f = np.linalg.lstsq(M, -g[nb:], rcond=None)[0]
        roots = np.roots(np.r_[1.0, f])
        if np.any(np.abs(roots) > 0.9999):  # reflect and cap, as the C++ does
            roots = np.where(np.abs(roots) > 1, 1 / np.conj(roots), roots)
            roots = np.where(np.abs(roots) > 0.9999, roots * 0.9999 / np.abs(roots), roots)
            f = np.real(np.poly(roots))[1:]
    b = np.array([g[k] + sum(f[i - 1] * gz[k - i + nf] for i in range(1, min(k, nf) + 1))
                  for k in range(nb)])
    return np.r_[b, f]


POLE_GRID = (-0.5, 0.0, 0.5, 0.8, 0.9, 0.95, 0.98)


def pole_grid(theta, y, u, chans, skip):
    """For each first-order-denominator channel (others held): the pole among Prony's and
    POLE_GRID whose least-squares b gives the lowest cost."""
    theta = theta.copy()
    k = 0
    for j, (nb, nf, d) in enumerate(chans):
        if nf == 1:
            others = theta.copy()
            others[k:k + nb] = 0.0
            r = (y - simulate(others, u, chans))[skip:]
            best = np.inf
            for pole in (-theta[k + nb],) + POLE_GRID:
                w = ss.lfilter(np.r_[np.zeros(d), 1.0], [1.0, -pole], u[:, j])
                W = np.column_stack([np.r_[np.zeros(i), w[:len(w) - i]] for i in range(nb)])[skip:]
                b = np.linalg.lstsq(W, r, rcond=None)[0]
                cost = np.sum((r - W @ b) ** 2)
                if cost < best:
                    best = cost
                    theta[k:k + nb], theta[k + nb] = b, -pole
        k += nb + nf
    return theta


def arx_oe(y, u, na, nb, delays, chans, fir_length, detrend="constant", start_length=30):
    """The whole per-window pipeline; returns (theta_oe, a, gains, firs)."""
    y = ss.detrend(y, type=detrend)
    u = ss.detrend(u, axis=0, type=detrend)
    theta_arx, _, _ = arx(y, u, na, nb, delays, delta=1e-4)
    a = np.r_[1.0, theta_arx[:na]]
    yf = ss.lfilter(a, [1.0], y)
    uf = ss.lfilter(a, [1.0], u, axis=0)
    theta0, k = [], na
    impulse = np.r_[1.0, np.zeros(start_length - 1)]
    for j, (cnb, cnf, _d) in enumerate(chans):
        g = ss.lfilter(theta_arx[k:k + nb[j]], a, impulse)
        k += nb[j]
        theta0.append(prony(g, cnb, cnf))
    theta = oe(yf, uf, chans, pole_grid(np.concatenate(theta0), yf, uf, chans, na), skip=na)
    gains, firs, k = [], [], 0
    for (cnb, cnf, d), L in zip(chans, fir_length):
        b, f = theta[k:k + cnb], np.r_[1.0, theta[k + cnb:k + cnb + cnf]]
        k += cnb + cnf
        gains.append(b.sum() / f.sum())
        firs.append(ss.lfilter(np.r_[np.zeros(d), b], f, np.r_[1.0, np.zeros(L - 1)]))
    return theta, a, np.array(gains), firs


def closed_loop(G, H, sigma, N, seeds, kp, ki, move_limit):
    """Stand-in closed loop for tests and studies (not the project's MPC simulator):
    y_i = sum_j G_ij u_j + H_i sigma_i e_i, each output i regulated to 0 by u_i with a
    velocity-form PI whose moves are clipped to +-move_limit_i (the clipping makes the
    controller nonlinear, so routine data without excitation are informative).

    G[i][j] = (b, f, d) or None, H[i] = (num, den); sigma, kp, ki, move_limit per output.
    Vectorised over seeds: returns y, u of shape (len(seeds), N, n).
    """
    n = len(G)
    S = len(seeds)
    v = np.empty((S, N, n))
    for s, seed in enumerate(seeds):
        e = np.random.default_rng(seed).standard_normal((N, n))
        for i in range(n):
            v[s, :, i] = ss.lfilter(*H[i], sigma[i] * e[:, i])
    chans = [(i, j, np.asarray(c[0], float), np.asarray(c[1], float) / c[1][0], int(c[2]))
             for i in range(n) for j, c in enumerate(G[i]) if c is not None]
    x = {(i, j): np.zeros((S, N)) for i, j, *_ in chans}
    y = np.zeros((S, N, n))
    u = np.zeros((S, N, n))
    err_prev = np.zeros((S, n))
    for t in range(N):
        y[:, t] = v[:, t]
        for i, j, b, f, d in chans:
            acc = np.zeros(S)
            for k, bk in enumerate(b):
                if t - d - k >= 0:
                    acc += bk * u[:, t - d - k, j]
            for k in range(1, min(len(f), t + 1)):
                acc -= f[k] * x[i, j][:, t - k]
            x[i, j][:, t] = acc
            y[:, t, i] += acc
        err = -y[:, t]
        move = kp * (err - err_prev) + ki * err
        u[:, t] = (u[:, t - 1] if t > 0 else 0.0) + np.clip(move, -move_limit, move_limit)
        err_prev = err
    return y, u


# The paper's SISO example (Section 5.1) and a PI for it: IMC rule for K = 1.05,
# tau = 10 samples, 17-sample delay (kc = tau / (K (lambda + theta)), lambda = theta,
# Ti = tau), moves clipped at 0.04 (the clip is active in about a third of the samples
# at sigma = 0.05).
PAPER_SISO = dict(G=[[([0.1003], [1.0, -0.9048], 17)]], H=[([1.0, -0.3], [1.0, 0.6])],
                  sigma=np.array([0.05]), kp=np.array([0.28]), ki=np.array([0.028]),
                  move_limit=np.array([0.04]))


def fir_regressors(u, fir, first):
    """Rows t = first..N-1: [u_j(t-d_j) .. u_j(t-d_j-nb_j+1) ...] with zeros before sample 0;
    fir = [(nb, d), ...]."""
    N = u.shape[0]
    cols = []
    for j, (nb, d) in enumerate(fir):
        for i in range(nb):
            col = np.zeros(N)
            col[d + i:] = u[:N - d - i, j]
            cols.append(col[first:])
    return np.column_stack(cols)


def fir_on_filtered(y, u, a, fir):
    """The OE step's FIR least squares on A(q)-filtered data over t >= na: (theta, Z, eps)."""
    na = len(a) - 1
    yf = ss.lfilter(a, [1.0], y)
    Z = fir_regressors(ss.lfilter(a, [1.0], u, axis=0), fir, na)
    theta = np.linalg.lstsq(Z, yf[na:], rcond=None)[0]
    return theta, Z, yf[na:] - Z @ theta


def two_step_fir_covariance(y, u, na, nb, delays, fir, arx_theta, fir_theta):
    """Sandwich covariance of the FIR estimate with the ARX step's uncertainty: influence
    w_t = z_t eps_t + M21 (Phi'Phi)^-1 phi_t e_t, M21 = d(Z' eps)/d a (dense form)."""
    N = len(y)
    a = np.r_[1.0, arx_theta[:na]]
    Phi, target = arx_regressors(y, u, na, nb, delays)
    t0 = N - len(target)
    e = target - Phi @ arx_theta
    yf = ss.lfilter(a, [1.0], y)
    Z = fir_regressors(ss.lfilter(a, [1.0], u, axis=0), fir, na)
    eps = yf[na:] - Z @ fir_theta
    Zraw = fir_regressors(u, fir, 0)
    vhat = y - Zraw @ fir_theta
    M21 = np.zeros((Z.shape[1], Phi.shape[1]))
    for k in range(1, na + 1):  # d z_t / d a_k = zraw_{t-k}, d eps_t / d a_k = vhat_{t-k}
        M21[:, k - 1] = Zraw[na - k:N - k].T @ eps + Z.T @ vhat[na - k:N - k]
    W = Z * eps[:, None]
    W[t0 - na:] += (Phi * e[:, None]) @ np.linalg.solve(Phi.T @ Phi, M21.T)
    ZZi = np.linalg.inv(Z.T @ Z)
    return ZZi @ (W.T @ W) @ ZZi * (N - na) / (N - na - Z.shape[1]), M21, Z


def _pem_residual(y, u, na, nb, nf, delay, stretches):
    """eps = A (y - G u) over t >= na of every stretch [a, b) (each filtered from rest), as a
    function of x = [b, f_1..f_nf, a_1..a_na]."""
    def residual(x):
        out = []
        for a, b in stretches:
            v = y[a:b] - ss.lfilter(np.r_[np.zeros(delay), x[:nb]], np.r_[1.0, x[nb:nb + nf]], u[a:b])
            out.append(ss.lfilter(np.r_[1.0, x[nb + nf:]], [1.0], v)[na:])
        return np.concatenate(out)
    return residual


def pem_ar_noise(y, u, na, nb, delay, detrend="constant", nf=1, stretches=None):
    """Joint prediction-error fit of y = q^-d B/F u + e / A (single input, F of order nf = 0 or
    1, A of order na): scipy least_squares on eps = A (y - G u) over t >= na, all of b, f, a at
    once, started from this module's ARX-OE. ``stretches``: rows [a, b) of a record with gaps
    laid end to end, each its own experiment from rest (default: one). Returns (b, f, a)."""
    y = ss.detrend(y, type=detrend)
    u = ss.detrend(u, type=detrend)
    theta0, a0, _, _ = arx_oe(y, u[:, None], na, [na + 1], [delay], [(nb, nf, delay)], [1], detrend="constant")
    residual = _pem_residual(y, u, na, nb, nf, delay, stretches or [(0, len(y))])
    x = so.least_squares(residual, np.r_[theta0, a0[1:]], method="lm", xtol=1e-14, ftol=1e-14,
                         gtol=1e-14, max_nfev=5000).x
    return x[:nb], np.r_[1.0, x[nb:nb + nf]], np.r_[1.0, x[nb + nf:]]


def pem_ar_noise_covariance(y, u, na, nb, delay, b, f, a, detrend="constant", stretches=None):
    """sigma^2 (J'J)^-1 of [b, f_1..f_nf, a_1..a_na] (nf = len(f) - 1, 0 or 1) with J the
    finite-difference Jacobian of the pem_ar_noise residual (scipy.optimize's approx_fprime-style
    central differences)."""
    y = ss.detrend(y, type=detrend)
    u = ss.detrend(u, type=detrend)
    residual = _pem_residual(y, u, na, nb, len(f) - 1, delay, stretches or [(0, len(y))])
    x0 = np.r_[b, f[1:], a[1:]]
    J = np.column_stack([(residual(x0 + h) - residual(x0 - h)) / (2 * h[i])
                         for i, h in enumerate(np.diag(1e-6 * np.maximum(np.abs(x0), 1e-3)))])
    eps = residual(x0)
    return eps @ eps / (len(eps) - len(x0)) * np.linalg.inv(J.T @ J)
