"""What a loop record says about its controller: the feedback sign from the output to an input
(the sign guard of ``identify`` and ``diagnose``'s loop pairing) and whether an input is exactly a
PID law of the output (a record that cannot determine the process)."""
from __future__ import annotations

import numpy as np


def controller_action(u, pv, sp, starts=()) -> int:
    """The feedback sign the data show from pv to the input u: +1 when the input moves with the control error
    sp - pv (the controller needs a positive process gain), -1 against it, 0 when no feedback
    shows. From the velocity form of a PI controller, du(t) = kc de(t) + ki e(t) (lag 0
    included: that is where the controller acts), by least squares with a 99.9 % t test on
    the proportional and integral terms together (they share the controller's sign).
    ``starts``: rows where a new stretch begins (rows laid end to end across gaps); the
    differences across them are left out."""
    e = (np.nanmean(pv) if sp is None else sp) - pv
    if not np.all(np.isfinite(e)):
        e = np.where(np.isfinite(e), e, np.nanmean(e))
    within = np.ones(len(u) - 1, dtype=bool)
    within[np.asarray(starts, dtype=int) - 1] = False
    du, de, e = np.diff(u)[within], np.diff(e)[within], e[1:][within]
    X = np.column_stack([de, e - e.mean(), np.ones(len(du))])
    coef, *_ = np.linalg.lstsq(X, du, rcond=None)
    resid = du - X @ coef
    dof = max(len(du) - 3, 1)
    cov = np.linalg.pinv(X.T @ X) * (resid @ resid / dof)
    # the sign-weighted sum kc/sd_kc + ki/sd_ki: both terms vote, the better determined more
    z = [coef[i] / np.sqrt(cov[i, i]) if cov[i, i] > 0 else 0.0 for i in (0, 1)]
    total = (z[0] + z[1]) / np.sqrt(2.0)
    return int(np.sign(total)) if abs(total) > 3.29 else 0


def controller_law_exact(u, pv, sp) -> bool:
    """Whether u is exactly a PID law of pv with nothing else moving it: the setpoint constant
    (or not given) and du(t) a linear function of e(t), e(t-1), e(t-2) (e = sp - pv) to rounding.
    A controller run at the sample rate on a record without setpoint moves: its OP carries no
    information the PV lags do not, the ARX regressors of the short dead times are collinear with
    the law, and the direct method's estimate is not determined by the data (the stiction study's
    flow loop, gain 1: gains of 0.24-0.30 came out, each as +- 15 %). A real controller scans
    faster than the historian samples, so its law is not exact at 10 s and this stays False."""
    if sp is not None and np.ptp(sp[np.isfinite(sp)]) > 0:
        return False
    e = -np.asarray(pv, dtype=float)   # sp - pv up to the constant setpoint, which the constant absorbs
    u = np.asarray(u, dtype=float)
    if not (np.all(np.isfinite(e)) and np.all(np.isfinite(u))) or len(u) < 10:
        return False
    du = np.diff(u)[1:]
    if not np.any(du):
        return False
    X = np.column_stack([e[2:], e[1:-1], e[:-2], np.ones(len(du))])
    coef, *_ = np.linalg.lstsq(X, du, rcond=None)
    return bool(np.sqrt(np.mean((du - X @ coef) ** 2)) <= 1e-6 * np.sqrt(np.mean(du**2)))
