"""A plain NumPy/SciPy implementation of the MPC in mpc.hpp and of its closed loop, written
from the equations (not from the C++): the independent reference for the tests and the
peer of bench/bench_simulate.py. Hard MV bounds and move limits only (no soft limits);
the QP is solved with quadprog.
"""
from __future__ import annotations

import numpy as np
import quadprog
from scipy.signal import lfilter


def full_numerator(num, delay):
    return np.concatenate([np.zeros(delay), np.asarray(num, float)])


class Channel:
    """y(t) = q^-delay num/den x(t), strictly proper, fed x(t-1) at step t (scipy state)."""

    def __init__(self, num, den, delay):
        b = full_numerator(num, delay)
        assert b[0] == 0.0
        self.b, self.a = b[1:], np.asarray(den, float)
        n = max(len(self.b), len(self.a)) - 1
        self.zi = np.zeros(max(n, 1) if n > 0 else 0)

    def step(self, x_prev):
        if self.zi.size == 0:
            return float(self.b[0] / self.a[0] * x_prev)
        y, self.zi = lfilter(self.b, self.a, [x_prev], zi=self.zi)
        return float(y[0])

    def run_held(self, x, steps):
        if self.zi.size == 0:
            return np.full(steps, self.b[0] / self.a[0] * x)
        y, _ = lfilter(self.b, self.a, np.full(steps, x), zi=self.zi)
        return y


def step_response(num, den, delay, n):
    return lfilter(full_numerator(num, delay), np.asarray(den, float), np.ones(n))


def dead_time(num, delay):
    num = np.asarray(num, float)
    return delay + int(np.argmax(num != 0))


class NumpyMpc:
    """process[i][j] = (num, den, delay) or None. Weights in engineering units; the MV target
    term normalised by the MV range (mv_max - mv_min, 1 if unbounded), as mpc.hpp documents."""

    def __init__(self, process, hp, hc, cv_target, mv_target, cv_weight, mv_target_weight, move_weight,
                 deviation_weight, mv_min, mv_max, max_move, u0, noise=None):
        """noise: None for the bias (DMC) disturbance, else [(num, den)] per output for the
        noise-model (C/Delta) disturbance."""
        self.ny, self.nu = len(process), len(process[0])
        self.noise = noise
        self.v_hist = [[] for _ in process]
        ny, nu = self.ny, self.nu
        self.hp, self.hc = hp, hc
        self.cv_target = np.asarray(cv_target, float)
        self.mv_target = np.asarray(mv_target, float)
        self.mv_min, self.mv_max = np.asarray(mv_min, float), np.asarray(mv_max, float)
        self.max_move = np.asarray(max_move, float)
        self.u0 = np.asarray(u0, float)
        self.u_prev = self.u0.copy()
        self.channels = [[Channel(*g) if g else None for g in row] for row in process]
        self.start = np.array([min((dead_time(g[0], g[2]) for g in row if g), default=1) for row in process])
        nmax = self.start.max() + hp
        theta = np.zeros((ny * hp, nu * hc))
        for i in range(ny):
            for j in range(nu):
                g = process[i][j]
                if not g:
                    continue
                s = step_response(*g, nmax)
                for k in range(hp):
                    for m in range(hc):
                        n = self.start[i] + k - m
                        if n >= 0:
                            theta[i * hp + k, m * nu + j] = s[n]
        self.theta = theta
        rng = self.mv_max - self.mv_min
        rng = np.where(np.isfinite(rng) & (rng > 0), rng, 1.0)
        self.wy = np.repeat(np.asarray(cv_weight, float), hp)
        self.wmove = np.tile(np.asarray(move_weight, float), hc)
        self.wtarget = np.tile(np.asarray(mv_target_weight, float) / rng**2, hc)
        self.wdev = np.tile(np.asarray(deviation_weight, float), hc)
        self.C = np.kron(np.tril(np.ones((hc, hc))), np.eye(nu))
        H = theta.T @ (self.wy[:, None] * theta) + np.diag(self.wmove) \
            + self.C.T @ ((self.wtarget + self.wdev)[:, None] * self.C)
        self.P = 2 * H

    def free_response(self, y):
        ny, hp = self.ny, self.hp
        x = self.u_prev - self.u0
        f = np.zeros(ny * hp)
        self.dist = np.zeros(ny)
        for i in range(ny):
            ym = sum(ch.step(x[j]) for j, ch in enumerate(self.channels[i]) if ch)
            self.dist[i] = y[i] - ym
            fi = np.full(hp, self.dist[i])
            d = self.start[i]
            if self.noise:
                fi += self.forecast_increments(i, d + hp - 1)[d - 1:]
            for j, ch in enumerate(self.channels[i]):
                if ch:
                    fi += ch.run_held(x[j], d + hp - 1)[d - 1:]
            f[i * hp:(i + 1) * hp] = fi
        self.f = f
        return f

    def forecast_increments(self, i, steps, impulse_terms=400):
        """sum_{s<=k} Delta vhat(t+s|t), k = 1..steps, with Delta v = H e: innovations by
        filtering the whole history with 1/H, forecasts by H's truncated impulse response."""
        self.v_hist[i].append(self.dist[i])
        v = np.asarray(self.v_hist[i])
        w = np.diff(v, prepend=v[0])  # Delta v(0) = 0
        num, den = self.noise[i]
        e = lfilter(den, num, w)[::-1]  # e(t), e(t-1), ...
        h = lfilter(num, den, np.r_[1.0, np.zeros(impulse_terms - 1)])
        ahead = [np.dot(h[k:k + len(e)], e[: impulse_terms - k]) for k in range(1, steps + 1)]
        return np.cumsum(ahead)

    def qp(self, y, clip=False):
        """The QP of this sample in quadprog's terms (minimise 1/2 z'Pz + q'z, C'z >= b); with
        clip the move limits are left out (they are applied to the first move afterwards)."""
        f = self.free_response(y)
        r = np.repeat(self.cv_target, self.hp)
        gap = np.tile(self.u_prev - self.mv_target, self.hc)
        q = 2 * self.theta.T @ (self.wy * (f - r)) + 2 * self.C.T @ (self.wtarget * gap)
        rows, rhs = [], []
        lo = np.tile(self.mv_min - self.u_prev, self.hc)
        hi = np.tile(self.mv_max - self.u_prev, self.hc)
        mm = np.tile(np.full(self.nu, np.inf) if clip else self.max_move, self.hc)
        eye = np.eye(self.nu * self.hc)
        for k in range(self.nu * self.hc):
            if np.isfinite(lo[k]):
                rows.append(self.C[k])
                rhs.append(lo[k])
            if np.isfinite(hi[k]):
                rows.append(-self.C[k])
                rhs.append(-hi[k])
            if np.isfinite(mm[k]):
                rows.append(eye[k])
                rhs.append(-mm[k])
                rows.append(-eye[k])
                rhs.append(-mm[k])
        return q, np.array(rows).reshape(-1, self.nu * self.hc), np.array(rhs)

    def step(self, y, constrained=True, clip=False):
        """The next input; clip: a DMC with move clipping (the first planned move clipped to
        +-max_move, then the input to [mv_min, mv_max])."""
        q, G, h = self.qp(y, clip)
        if constrained and len(h):
            z = quadprog.solve_qp(self.P, -q, G.T, h)[0]
        else:
            z = np.linalg.solve(self.P, -q)
        du = np.clip(z[: self.nu], -self.max_move, self.max_move) if clip else z[: self.nu]
        self.u_prev = np.clip(self.u_prev + du, self.mv_min, self.mv_max) if clip else self.u_prev + du
        return self.u_prev.copy()


def closed_loop(process_model, process_truth, noise, sigma, y0, seed, n, mpc: NumpyMpc):
    """The same closed loop in NumPy (no events): y(t) = y0 + G0 (u - u0) + H0 sigma e."""
    rng = np.random.default_rng(seed)
    ny, nu = mpc.ny, mpc.nu
    plant = [[Channel(*g) if g else None for g in row] for row in process_truth]
    v = np.column_stack([lfilter(full_numerator(h[0], h[2]), h[1], sigma[i] * rng.standard_normal(n))
                         for i, h in enumerate(noise)])
    U, Y = np.zeros((n, nu)), np.zeros((n, ny))
    u = mpc.u0.copy()
    for t in range(n):
        x = u - mpc.u0
        y = np.array([y0[i] + v[t, i] + sum(ch.step(x[j]) for j, ch in enumerate(plant[i]) if ch)
                      for i in range(ny)])
        u = mpc.step(y)
        U[t], Y[t] = u, y
    return U, Y
