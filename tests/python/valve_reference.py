"""Plain Python valve models written out from the published equations, as the independent
reference for mpmpp's C++ valves (tests and bench)."""
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
