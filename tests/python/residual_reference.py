"""A plain NumPy/SciPy implementation of one window of the residual regression
(cpp/src/residual_regression.cpp): the output error y - G0 u regressed on the Laguerre and
delay directions (Laguerre alone for a channel the model lacks) after whitening by A(q), with
A(q) refitted from what beta leaves, twice;
both fits with up to `breaks` step + hinge pairs chosen greedily by brute force (every
position's two columns built and projected explicitly), on the rows that read no outlier and
no missing output sample (NaN in y); a missing input sample held at the last value present (the
first one after it at the start)."""
import numpy as np
from scipy.signal import lfilter


def _tf(num, den, delay, x):
    return lfilter(np.concatenate([np.zeros(delay), num]), den, x)


def _pole(g):
    den = np.asarray(g.den)
    return float(np.clip(np.max(np.abs(np.roots(den))) if len(den) > 1 else 0.5, 0.2, 0.99))


def _laguerre(p, x, terms, lag=1):
    """L_0 .. L_{terms-1} of x with pole p, L_0 = c q^-lag / (1 - p q^-1)."""
    c = np.sqrt(1 - p * p)
    cur = lfilter(np.concatenate([np.zeros(lag), [c]]), [1.0, -p], x)
    cols = []
    for _ in range(terms):
        cols.append(cur)
        cur = lfilter([-p, 1.0], [1.0, -p], cur)
    return cols


def _directions(g, x, terms):
    num, den, d = np.asarray(g.num), np.asarray(g.den), int(g.delay)
    cols = [_tf(num, den, d, x), _tf(num, den, d + 1, x), _tf(num, den, d - 1 if d >= 2 else d + 2, x)]
    return np.column_stack(cols + _laguerre(_pole(g), x, terms))


def _absent_directions(modelled, x, terms):
    """A channel the model lacks: Laguerre filters with the slowest pole of the output's
    modelled channels, the first responding at their shortest delay."""
    lag = max(min(int(g.delay) for g in modelled), 1)
    return np.column_stack(_laguerre(max(_pole(g) for g in modelled), x, terms, lag))


def _lstsq(Z, z):
    """Least squares on the column-scaled regressors by a truncated SVD, and sigma^2 (Z'Z)^+."""
    scale = np.sqrt((Z**2).mean(0))
    scale[scale == 0] = 1.0
    U, s, Vt = np.linalg.svd(Z / scale, full_matrices=False)
    k = s > 1e-8 * s[0]
    bs = Vt[k].T @ ((U[:, k].T @ z) / s[k])
    sigma2 = np.sum((z - (Z / scale) @ bs) ** 2) / (len(z) - k.sum())
    Vs = Vt[k].T / s[k]
    return bs / scale, sigma2 * (Vs @ Vs.T) / np.outer(scale, scale)


def best_break(Z, e, edge):
    """(k, score): the step + hinge pair at row k whose chi-square(2) score
    e'X (X'MX)^-1 X'e / sigma^2 (M = I - P_Z) is largest, by explicit projection."""
    n = len(e)
    U, sv, _ = np.linalg.svd(Z, full_matrices=False)
    Q = U[:, sv > 1e-10 * sv[0]]  # an orthonormal basis of Z's columns
    sigma2 = e @ e / (n - Q.shape[1])
    t = np.arange(n, dtype=float)
    best = (-1, 0.0)
    for k in range(edge, n - edge):
        X = np.column_stack([(t >= k).astype(float), np.maximum(0.0, t - k)])
        MX = X - Q @ (Q.T @ X)
        xe = X.T @ e
        score = xe @ np.linalg.solve(X.T @ MX, xe) / sigma2
        if score > best[1]:
            best = (k, score)
    return best


def _fit(Z, z, breaks, edge, threshold):
    coef, cov = _lstsq(Z, z)
    for _ in range(breaks):
        k, score = best_break(Z, z - Z @ coef, edge)
        if k < 0 or score < threshold:
            break
        t = np.arange(len(z), dtype=float)
        Z = np.column_stack([Z, (t >= k).astype(float), np.maximum(0.0, t - k)])
        coef, cov = _lstsq(Z, z)
    return coef, cov


def usable_rows(v, na):
    """Rows of the AR fit (row i reads v[i .. i + na]) that read no missing sample."""
    return np.array([i for i in range(len(v) - na) if np.all(np.isfinite(v[i:i + na + 1]))], dtype=int)


def rows_clear_of_outliers(v, trend, na, sigmas, memory=0):
    """Rows of the AR fit (row i reads v[i .. i + na]) reading no missing sample and no sample
    whose innovation in a first AR fit on those rows exceeds `sigmas` robust sigmas (1.4826
    MAD), nor the `memory` samples after it (a moving-average root's filter carries its tail);
    all of them when none is, or more than a tenth of them would go."""
    usable = usable_rows(v, na)
    if sigmas <= 0:
        return usable
    R = np.column_stack([v[na - k:len(v) - k] for k in range(1, na + 1)] + [trend])[usable]
    e = v[na:][usable] - R @ _lstsq(R, v[na:][usable])[0]
    med = np.median(e)
    limit = sigmas * 1.4826 * np.median(np.abs(e - med))
    out = np.zeros(len(trend), bool)
    for i in usable[np.abs(e - med) > limit]:
        out[i:i + na + memory + 1] = True
    if not out[usable].any() or out[usable].sum() > len(usable) // 10:
        return usable
    return usable[~out[usable]]


def held(U):
    """U with each missing sample held at the last value present (the first after it at the start)."""
    U = U.copy()
    for e in range(U.shape[1]):
        present = np.flatnonzero(np.isfinite(U[:, e]))
        for t in np.flatnonzero(~np.isfinite(U[:, e])):
            before = present[present < t]
            U[t, e] = U[before[-1], e] if len(before) else U[present[0], e]
    return U


def reference_window(g, y, u, na, terms, settle, breaks=0, significance=0.01, outlier_sigmas=0.0, ma_root=0.0):
    """One channel g (a TransferFunction) of input u: (beta, its covariance, A(q)'s ar, theirs)."""
    b, cov, ar, ar_cov = reference_window_miso([g], y, u[:, None], na, terms, 0, settle, breaks,
                                               significance, outlier_sigmas, ma_root)
    return b[0], cov[0], ar, ar_cov


def reference_window_miso(channels, y, U, na, terms, absent_terms, settle, breaks=0, significance=0.01,
                          outlier_sigmas=0.0, ma_root=0.0):
    """channels[e]: the model's channel from column e of U, or None where the model lacks one
    (its absent_terms Laguerre directions alone). Per input: beta_e and its covariance; then
    A(q)'s ar and covariance. ma_root c: v and X through 1 / (1 - c q^-1) first, a lost output
    sample unknown for the filter's memory (c^k >= 1 %) after it."""
    modelled = [g for g in channels if g is not None]
    U = held(U)
    yc, Uc = y - np.nanmean(y), U - U.mean(0)
    v = yc.copy()
    blocks = []
    for g, x in zip(channels, Uc.T):
        if g is None:
            blocks.append(_absent_directions(modelled, x, absent_terms))
            continue
        v -= _tf(np.asarray(g.num), np.asarray(g.den), int(g.delay), x)
        blocks.append(_directions(g, x, terms))
    X = np.column_stack(blocks)
    memory = int(np.ceil(np.log(0.01) / np.log(ma_root))) if ma_root else 0
    if memory:
        lost = np.flatnonzero(~np.isfinite(v))
        v = lfilter([1.0], [1.0, -ma_root], np.nan_to_num(v))
        X = lfilter([1.0], [1.0, -ma_root], X, axis=0)
        for t in lost:
            v[t:t + memory + 1] = np.nan
    skip = min(settle, len(y) // 3)
    v, X = v[skip:], X[skip:]
    rows = len(v) - na
    trend = np.column_stack([np.ones(rows), np.linspace(0.0, 1.0, rows)])
    kept = rows_clear_of_outliers(v, trend, na, outlier_sigmas, memory)
    edge = max(na + 1, len(kept) // 20)
    threshold = -2.0 * np.log(significance / max(len(kept) - 2 * edge, 1))  # chi-square(2), Bonferroni
    b = np.zeros(X.shape[1])
    for _ in range(2):
        r = v - X @ b
        R = np.column_stack([r[na - k:len(r) - k] for k in range(1, na + 1)] + [trend])
        a_coef, a_cov = _fit(R[kept], r[na:][kept], breaks, edge, threshold)
        a = a_coef[:na]
        A = np.concatenate([[1.0], -a])
        coef, cov = _fit(np.column_stack([lfilter(A, [1.0], X, axis=0)[na:], trend])[kept],
                         lfilter(A, [1.0], v)[na:][kept], breaks, edge, threshold)
        b = coef[:X.shape[1]]
    edges = np.cumsum([0] + [blk.shape[1] for blk in blocks])
    # A(q) of the last pass in the ARX step's signs (A = 1 + ar_1 q^-1 + ...), with its covariance.
    return ([b[lo:hi] for lo, hi in zip(edges[:-1], edges[1:])],
            [cov[lo:hi, lo:hi] for lo, hi in zip(edges[:-1], edges[1:])], -a, a_cov[:na, :na])
