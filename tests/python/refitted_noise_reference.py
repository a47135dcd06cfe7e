"""The refitted-noise onset gains (mpmpp.diagnose.refitted_noise) with NumPy: per-row lag outer
products summed per onset block and fold (reduceat), suffix sums, batched AR solves. The
bench's named peer of the C++ kernel (the tests check both against plain least squares)."""
import numpy as np


def lag_vectors(x, order):
    """Rows z_t = (x_t, x_{t-1}, ..., x_{t-order}), zeros before the start."""
    z = np.zeros((len(x), order + 1))
    for k in range(order + 1):
        z[k:, k] = x[: len(x) - k]
    return z


def ar_errors(gram, score_gram):
    """AR fitted on stacked lag Gram matrices, its error sums on them and on ``score_gram``."""
    a = np.linalg.solve(gram[..., 1:, 1:], gram[..., 1:, 0:1])[..., 0]
    c = np.concatenate([np.ones(a.shape[:-1] + (1,)), -a], axis=-1)
    return (np.einsum("...i,...ij,...j->...", c, gram, c), np.einsum("...i,...ij,...j->...", c, score_gram, c))


def numpy_onset_gains(e, psi, folds, onsets, order):
    """(in_fold, held_out), each (onsets, 2), as RefittedNoise(e, folds, onsets, order).gains(psi)."""
    ze, zp = lag_vectors(e, order), lag_vectors(psi, order)
    rows = np.array([f.sum() for f in folds])
    gram = np.stack([(ze * f[:, None]).T @ ze for f in folds])
    nominal_fit, nominal_held = ar_errors(gram, gram[::-1])
    weight = folds[0] + folds[1]
    label = np.where(folds[0] > 0, 0, np.where(folds[1] > 0, 1, -1))
    changes = np.flatnonzero(np.diff(label)) + 1
    starts = np.unique(np.r_[onsets, changes[changes > onsets[0]]])
    per_row = ((zp - 2.0 * ze) * weight[:, None])[:, :, None] * zp[:, None, :]
    blocks = np.add.reduceat(per_row.reshape(len(zp), -1), starts, axis=0)
    m = np.zeros((len(onsets), 2, (order + 1) ** 2))
    keep = label[starts] >= 0
    np.add.at(m, ((np.searchsorted(onsets, starts, side="right") - 1)[keep], label[starts][keep]), blocks[keep])
    m = np.cumsum(m[::-1], axis=0)[::-1].reshape(len(onsets), 2, order + 1, order + 1)
    m = 0.5 * (m + np.swapaxes(m, 2, 3)) + gram[None]
    fit, held = ar_errors(m, m[:, ::-1])
    return rows * np.log(nominal_fit / fit), rows[::-1] * np.log(nominal_held / held)
