"""Plain Python valve models written out from the published equations, as the independent
reference for mpmpp's C++ valves, and the valve fit's held-out errors by one least-squares fit
per fold (tests and bench)."""
import numpy as np


def choudhury_reference(x, S, J):
    """Choudhury et al. (2005) stick-slip flowchart, written out sample by sample."""
    y = np.empty_like(x)
    y[0] = x[0]
    stuck, xss, direction = True, x[0], 0
    for k in range(1, len(x)):
        v = np.sign(x[k] - x[k - 1])
        if not stuck and v != direction:
            stuck, xss = True, x[k - 1]
        if stuck:
            d = np.sign(x[k] - xss)
            need = J if d == direction else S
            if d != 0 and abs(x[k] - xss) > need:
                stuck, direction = False, d
                y[k] = x[k] - d * (S - J) / 2
            else:
                y[k] = y[k - 1]
        else:
            y[k] = x[k] - direction * (S - J) / 2
    return y


def he_reference(x, fs, fd):
    """He et al. (2007) two-parameter model: u_r accumulates the OP change while stuck."""
    y = np.empty_like(x)
    y[0], ur = x[0], 0.0
    for k in range(1, len(x)):
        cum = ur + x[k] - x[k - 1]
        if abs(cum) > fs:
            y[k], ur = x[k] - np.sign(cum) * fd, np.sign(cum) * fd
        else:
            y[k], ur = y[k - 1], cum
    return y


def per_fold_lstsq_losses(x, target, folds):
    """Squared one-step errors of each row by the least squares (numpy.linalg.lstsq) on the
    other ``folds`` contiguous blocks of rows."""
    edges = np.linspace(0, len(target), folds + 1).astype(int)
    losses = np.empty(len(target))
    for a, b in zip(edges[:-1], edges[1:]):
        keep = np.r_[0:a, b:len(target)]
        theta = np.linalg.lstsq(x[keep], target[keep], rcond=None)[0]
        losses[a:b] = (target[a:b] - x[a:b] @ theta) ** 2
    return losses
