"""Choudhury's higher-order-statistics test (Choudhury, Shah & Thornhill 2004, Automatica
40:1719-1728): squared bicoherence, the non-Gaussianity and nonlinearity indices (NGI, NLI),
and the apparent stiction from an ellipse fitted to the PV-OP plot.

Squared bicoherence by the direct (segment-averaged FFT) method,
  bic^2(f1, f2) = |E[X(f1) X(f2) X*(f1+f2)]|^2 / (E[|X(f1) X(f2)|^2] E[|X(f1+f2)|^2] + eps),
over the principal domain 0 < f2 <= f1, f1 + f2 <= 1/2. A value is significant when it
exceeds chi2_alpha(2) / (2K) for K segments;
  NGI = mean of the significant bic^2 - chi2_alpha(2) / (2K),
  NLI = |max bic^2 - (mean bic^2 + 2 std bic^2)| over the significant values.
Under Gaussianity the NGI so defined is of order 1/K (the mean excess of a chi-square tail
over its quantile), so with the K of about 20 segments a 2 h record gives, the published
NGI threshold of 0.001 (long records) flags noise; the thresholds below are chosen on data.
"""
from __future__ import annotations

import numpy as np

# Published thresholds (Choudhury et al. 2004): NGI 0.001, NLI 0.01. Ours are chosen on the
# TUNING families of studies/stiction_benchmark.py.
NGI_THRESHOLD = 0.0027
NLI_THRESHOLD = 0.027
CHI2_2_95 = 5.991464547107979  # chi-square quantile, 2 degrees of freedom, alpha = 0.05


def squared_bicoherence(x, nfft: int = 64, overlap: float = 0.5, eps: float = 0.0):
    """Return (bic2 over the principal domain as an (nfft/2, nfft/2) array with NaN outside,
    number of segments K)."""
    x = np.asarray(x, float)
    if len(x) < 2 * nfft:
        raise ValueError(f"too short for bicoherence: {len(x)} samples (need >= {2 * nfft})")
    x = x - x.mean()
    step = max(1, int(nfft * (1 - overlap)))
    starts = range(0, len(x) - nfft + 1, step)
    window = np.hanning(nfft)
    segs = np.array([x[s:s + nfft] - x[s:s + nfft].mean() for s in starts]) * window
    k = len(segs)
    spec = np.fft.fft(segs, axis=1)
    half = nfft // 2
    f1, f2 = np.meshgrid(np.arange(half), np.arange(half), indexing="ij")
    inside = (f2 >= 1) & (f2 <= f1) & (f1 + f2 < half)
    a, b, c = spec[:, f1], spec[:, f2], spec[:, (f1 + f2) % nfft]
    triple = np.abs((a * b * np.conj(c)).mean(axis=0)) ** 2
    denom = (np.abs(a * b) ** 2).mean(axis=0) * (np.abs(c) ** 2).mean(axis=0) + eps
    with np.errstate(invalid="ignore", divide="ignore"):
        bic = np.where(inside & (denom > 0), triple / np.where(denom > 0, denom, 1.0), np.nan)
    return bic, k


def ngi_nli(x, nfft: int = 64) -> tuple[float, float]:
    bic, k = squared_bicoherence(x, nfft=nfft)
    values = bic[np.isfinite(bic)]
    critical = CHI2_2_95 / (2 * k)
    significant = values[values > critical]
    if significant.size == 0:
        return -critical, 0.0
    ngi = significant.mean() - critical
    nli = abs(values.max() - (significant.mean() + 2 * significant.std()))
    return float(ngi), float(nli)


def fit_ellipse(x, y) -> np.ndarray:
    """Least-squares conic a x^2 + b x y + c y^2 + d x + e y = 1 on centred data."""
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    design = np.column_stack([x * x, x * y, y * y, x, y])
    coef, *_ = np.linalg.lstsq(design, np.ones_like(x), rcond=None)
    return coef


def apparent_stiction(op, pv) -> float:
    """Width along OP of the fitted PV-OP ellipse at the PV's mean (Choudhury's size measure);
    0 when the fit is not an ellipse."""
    u = np.asarray(op, float) - np.mean(op)
    y = np.asarray(pv, float) - np.mean(pv)
    a, b, c, d, _ = fit_ellipse(u, y)
    if b * b - 4 * a * c >= 0:
        return 0.0
    # chord at y = 0: a x^2 + d x - 1 = 0
    disc = d * d + 4 * a
    return float(np.sqrt(disc) / abs(a)) if disc > 0 and a != 0 else 0.0


def bicoherence_test(op, pv, sp=None) -> tuple[bool, dict]:
    """Nonlinearity (NGI and NLI above threshold) in the control error, sized by the ellipse."""
    pv = np.asarray(pv, float)
    error = (np.zeros_like(pv) if sp is None else np.asarray(sp, float)) - pv
    ngi, nli = ngi_nli(error)
    verdict = ngi > NGI_THRESHOLD and nli > NLI_THRESHOLD
    size = apparent_stiction(op, pv) if verdict else 0.0
    return verdict, {"NGI": ngi, "NLI": nli, "apparent_stiction": size}
