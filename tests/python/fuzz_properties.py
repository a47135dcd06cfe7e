"""Property-based fuzzing of the engine's boundary (hypothesis).

Not collected by pytest directly: test_fuzz.py runs this file in a child pytest so that a
segfault or abort in C++ is reported as a failing test (with faulthandler's traceback)
instead of killing the test session. MPMPP_FUZZ_EXAMPLES scales every property
(default 40: CI-sized; `python studies/fuzz_long.py` runs 2000). Each example has a deadline,
and the child a wall-clock limit, so a hang is a failure too.

Every property says what a correct outcome is, not only "no crash":
- readers: a valid object that round-trips exactly, or a one-line ValueError;
- TransferFunction: constructed ones filter like scipy.signal.lfilter (delay prepended);
- QP: 'solved' is feasible and optimal against quadprog, 'infeasible' is confirmed by an LP
  (scipy linprog), 'non_convex' only when P has a non-positive eigenvalue;
- ARX-OE: a finite estimate, or a RuntimeError saying why the window is not informative;
- SVM: the nu-property (outlier fraction <= nu <= support-vector fraction) on the training set.
"""
import json
import math
import os
import string

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import mpmpp
from mpmpp import _core, identify
from qp_reference import reference_solve  # tests/python helper (quadprog, OSQP fallback)

EXAMPLES = int(os.environ.get("MPMPP_FUZZ_EXAMPLES", "40"))
SETTINGS = settings(max_examples=EXAMPLES, deadline=5000, derandomize=EXAMPLES <= 40,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def one_line_value_error(exc):
    assert isinstance(exc, ValueError), f"{type(exc).__name__}: {exc}"
    assert "\n" not in str(exc) and str(exc), repr(str(exc))


# ---------------------------------------------------------------- model JSON reader

VALID_MODEL = json.dumps({
    "name": "fuzz", "sample_time_s": 5.0, "inputs": ["u1", "u2"], "outputs": ["y"],
    "process": {"y": {"u1": {"num": [0.1, 0.05], "den": [1.0, -0.9], "delay": 2},
                      "u2": {"gain": 1.5, "time_constant_s": 30.0, "dead_time_s": 7.5}}},
    "noise": {"y": {"num": [1.0, -0.3], "den": [1.0, 0.5]}},
}, indent=1)

ODD_TOKENS = ["1e400", "-1e400", "NaN", "Infinity", "null", "true", "[]", "{}", "\"\"", "-0",
              "1e-400", "123456789012345678901234567890", "\"\\u0000\"", "\"\\ud800\"", "\u00e9",
              "\u202e", "\U0001f600", "\x00", "\"delay\": 2147483648", "\"den\": [0]", ","]


@st.composite
def mutated_text(draw, valid):
    text = valid
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["truncate", "flip", "insert", "delete", "token", "key"]))
        pos = draw(st.integers(0, len(text)))
        if kind == "truncate":
            text = text[:pos]
        elif kind == "flip" and pos < len(text):
            text = text[:pos] + chr(ord(text[pos]) ^ (1 << draw(st.integers(0, 6)))) + text[pos + 1:]
        elif kind == "insert":
            text = text[:pos] + draw(st.text(max_size=8)) + text[pos:]
        elif kind == "delete":
            text = text[:pos] + text[pos + draw(st.integers(1, 20)):]
        elif kind == "token":
            text = text[:pos] + draw(st.sampled_from(ODD_TOKENS)) + text[pos:]
        else:  # a random key where an object starts
            starts = [i for i, c in enumerate(text) if c == "{"]
            if starts:
                i = draw(st.sampled_from(starts)) + 1
                key = json.dumps(draw(st.text(alphabet=string.printable + "\u00e9\u4e2d", max_size=6)))
                text = text[:i] + key + ": 1, " + text[i:]
    return text


@SETTINGS
@given(mutated_text(VALID_MODEL))
def test_model_reader_mutations(text):
    try:
        model = mpmpp.Model.from_json(text, "fuzz.json")
    except ValueError as exc:
        one_line_value_error(exc)
        assert str(exc).startswith("fuzz.json: ")
        return
    # Accepted: load-save-load is exact.
    again = mpmpp.Model.from_json(model.to_json())
    assert again == model and again.to_json() == model.to_json()


@SETTINGS
@given(mutated_text(VALID_MODEL))
def test_model_file_mutations(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("m") / "model.json"
    path.write_bytes(text.encode("utf-8", "surrogatepass"))
    try:
        model = mpmpp.load_model(path)
    except ValueError as exc:
        one_line_value_error(exc)
        return
    out = path.with_name("saved.json")
    mpmpp.save_model(model, out)
    assert mpmpp.load_model(out) == model


# ---------------------------------------------------------------- CSV reader

VALID_CSV = "time,u1,u2,y,y_sp,extra\n" + "".join(
    f"{5 * k},{math.sin(k):.6g},{k % 3},{0.1 * k:.3f},52.0,{'' if k == 4 else k}\n" for k in range(15))


@SETTINGS
@given(mutated_text(VALID_CSV))
def test_csv_reader_mutations(text):
    try:
        table = _core.parse_csv(text, "fuzz.csv")
    except ValueError as exc:
        one_line_value_error(exc)
        assert str(exc).startswith("fuzz.csv")
        return
    values = np.asarray(table.values)
    time_s = np.asarray(table.time_s)
    assert values.shape == (len(time_s), len(table.columns))
    assert np.all(np.isfinite(time_s)) and np.all(np.diff(time_s) > 0)
    assert not np.isinf(values).any()
    assert list(table.missing) == list(np.isnan(values).sum(axis=0))


@SETTINGS
@given(st.lists(st.lists(st.one_of(st.floats(-9.99e99, 9.99e99, allow_nan=False, width=64),
                                   st.just(float("nan"))), min_size=2, max_size=2), min_size=1, max_size=20),
       st.integers(0, 10**6))
def test_csv_write_read_exact(rows, t0):
    """Any table that save_data accepts (finite below 1e100 in magnitude, or NaN) reads back bit
    for bit (NaN stays NaN)."""
    import pandas as pd
    import tempfile
    df = pd.DataFrame(rows, columns=["a", "b"])
    df.insert(0, "time", t0 + np.arange(len(rows), dtype=float))
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "data.csv")
        mpmpp.save_data(path, df)
        back = mpmpp.load_data(path)
    np.testing.assert_array_equal(back[["time", "a", "b"]].to_numpy(), df.to_numpy())


# ---------------------------------------------------------------- TransferFunction

coefficient = st.one_of(st.floats(-10, 10), st.just(0.0), st.sampled_from([1e-300, -1e300, 1e300, 5e-324]))


@SETTINGS
@given(st.lists(coefficient, min_size=0, max_size=6), st.lists(coefficient, min_size=0, max_size=6),
       st.integers(-3, 40), st.lists(st.floats(-1e3, 1e3), max_size=30))
def test_transfer_function(num, den, delay, x):
    from scipy.signal import lfilter
    try:
        g = mpmpp.TransferFunction(np.array(num, dtype=float), np.array(den, dtype=float), delay)
    except ValueError as exc:
        one_line_value_error(exc)
        assert not num or not den or den[0] == 0 or delay < 0
        return
    x = np.asarray(x, dtype=float)
    with np.errstate(all="ignore"):
        expected = lfilter(np.r_[np.zeros(delay), num], den, x) if x.size else x
        got = g.filter(x)
        finite = np.isfinite(expected) & (np.abs(expected) < 1e200)
    assert got.shape == x.shape
    np.testing.assert_allclose(got[finite], expected[finite], rtol=1e-7, atol=1e-9 * (1 + np.abs(expected[finite]).max(initial=0)))
    # Every other operation returns or raises a ValueError; none crashes.
    str(g), g.dc_gain(), g.is_stable(), g.is_minimum_phase(), g.step(5), g.impulse(0)
    for combine, expected_delay in ((g.series, 2 * delay), (g.parallel, delay), (lambda _: g.inverse(), 0)):
        try:  # extreme coefficients may overflow to inf: a ValueError then, never a crash
            assert combine(g).delay == expected_delay
        except ValueError as exc:
            one_line_value_error(exc)


# ---------------------------------------------------------------- QP

@st.composite
def qp_problems(draw):
    n = draw(st.integers(1, 6))
    mc = draw(st.integers(0, 8))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    rank = draw(st.integers(0, n))  # rank < n: semidefinite (degenerate) P
    F = rng.normal(size=(n, rank))
    P = F @ F.T + draw(st.sampled_from([0.0, 1e-12, 1e-3, 1.0])) * np.eye(n)
    P = 0.5 * (P + P.T)
    q = rng.normal(size=n) * draw(st.sampled_from([1.0, 1e-8, 1e6]))
    A = rng.normal(size=(mc, n))
    if mc >= 2 and draw(st.booleans()):
        A[1] = A[0]  # duplicated (dependent) constraint rows
    centre = A @ rng.normal(size=n)
    width = np.abs(rng.normal(size=mc)) * draw(st.sampled_from([0.0, 1e-9, 1.0]))
    l, u = centre - width, centre + width
    kinds = rng.integers(0, 4, size=mc)
    l[kinds == 1] = -np.inf
    u[kinds == 2] = np.inf
    if mc and draw(st.booleans()):  # shift a row's interval away: may make the problem infeasible
        shift = rng.normal() * 10
        k = rng.integers(mc)
        l[k], u[k] = l[k] + shift, u[k] + shift
        if mc >= 2 and np.array_equal(A[0], A[1]):
            l[0], u[0] = centre[1] - 2.0, centre[1] - 1.5  # contradicts its twin unless row 1 is open
            l[1], u[1] = centre[1] - width[1], centre[1] + width[1]
    return P, q, A, l, u


def lp_feasible(A, l, u):
    from scipy.optimize import linprog
    n = A.shape[1]
    rows, rhs = [], []
    for k in range(A.shape[0]):
        if np.isfinite(u[k]):
            rows.append(A[k]), rhs.append(u[k])
        if np.isfinite(l[k]):
            rows.append(-A[k]), rhs.append(-l[k])
    if not rows:
        return True, 0.0
    # minimise the largest violation s: A x - s <= u, -A x - s <= -l.
    G = np.hstack([np.array(rows), -np.ones((len(rows), 1))])
    res = linprog(np.r_[np.zeros(n), 1.0], A_ub=G, b_ub=np.array(rhs), bounds=[(None, None)] * n + [(0, None)])
    violation = max(res.x[-1], 0.0) if res.status == 0 else np.inf
    return violation <= 1e-7, violation


@SETTINGS
@given(qp_problems())
def test_qp_status_is_right(problem):
    P, q, A, l, u = problem
    res = mpmpp.solve_qp(P, q, A, l, u)
    lam_min = np.linalg.eigvalsh(P).min()
    feasible, violation = lp_feasible(A, l, u)
    scale = 1 + np.abs(A).sum(axis=1).max(initial=0) * (1 + np.abs(res.x).max(initial=0))
    if res.status == "solved":
        Ax = A @ res.x
        assert np.all(Ax >= l - 1e-6 * scale) and np.all(Ax <= u + 1e-6 * scale)
        # Optimal: no feasible direction improves; compare with quadprog when P is clearly PD.
        if lam_min > 1e-6 and violation == 0.0:
            try:
                x_ref = reference_solve(P, q, A, l, u)
            except (ValueError, RuntimeError):  # the references give up on some degenerate rows
                return
            f = lambda x: 0.5 * x @ P @ x + q @ x  # noqa: E731
            assert f(res.x) <= f(x_ref) + 1e-6 * (1 + abs(f(x_ref)))
    elif res.status == "primal_infeasible":
        assert violation > 1e-12, f"reported infeasible but an LP meets every row (violation {violation})"
    elif res.status == "non_convex":
        assert lam_min <= 1e-8 * max(1.0, np.abs(P).max()), f"non_convex with lambda_min {lam_min}"
    else:
        assert res.status == "max_iterations"


# ---------------------------------------------------------------- ARX-OE

@SETTINGS
@given(st.integers(0, 2**32 - 1), st.integers(0, 400), st.integers(0, 6), st.integers(1, 6), st.integers(0, 8),
       st.sampled_from(["foptd", "fir", "oe"]), st.sampled_from(["none", "mean", "linear"]),
       st.sampled_from(["white", "constant", "step", "nan_run", "huge", "tiny"]))
def test_arx_oe(seed, n, na, nb, delay, structure, detrend, signal):
    rng = np.random.default_rng(seed)
    u = rng.normal(size=n)
    y = np.convolve(u, [0, 0.5, 0.3, 0.1])[:n] + 0.1 * rng.normal(size=n) if n else np.zeros(0)
    if signal == "constant":
        u[:] = 1.0
    elif signal == "step":
        u = (np.arange(n) > n // 2).astype(float)
    elif signal == "nan_run" and n > 10:
        y[n // 3: n // 3 + 5] = np.nan
    elif signal == "huge":
        u, y = u * 1e150, y * 1e150
    elif signal == "tiny":
        u, y = u * 1e-150, y * 1e-150
    try:
        r = identify.arx_oe(y, u, na, nb, delay, structure=structure, oe_nb=2, oe_nf=1, fir_length=30,
                            detrend=detrend)
    except RuntimeError as exc:
        assert "window" in str(exc) or "not informative" in str(exc), str(exc)
        return
    except ValueError as exc:
        one_line_value_error(exc)
        return
    assert signal not in ("constant", "nan_run") or n <= 10
    c = r.channels[0]
    assert np.all(np.isfinite(c.b)) and np.all(np.isfinite(c.f)) and np.all(np.isfinite(c.fir))
    assert np.all(np.isfinite(r.noise)) and len(c.fir) == 30


@SETTINGS
@given(st.integers(0, 2**32 - 1), st.integers(1, 300), st.integers(1, 300))
def test_arx_oe_windows_flags(seed, window, step):
    rng = np.random.default_rng(seed)
    n = 400
    u = rng.normal(size=n)
    y = np.convolve(u, [0, 0.5, 0.3])[:n] + 0.1 * rng.normal(size=n)
    y[rng.integers(0, n, size=3)] = np.nan
    result = identify.arx_oe_windows(y, u, window, step, 2, 2, 1, fir_length=10)
    assert [w.start for w in result] == list(range(0, n - window + 1, step))
    for w in result:
        has_nan = np.isnan(y[w.start:w.start + window]).any()
        assert not (has_nan and w.ok), "a window with missing samples was estimated"
        assert w.ok or w.message


# ---------------------------------------------------------------- one-class SVM

@SETTINGS
@given(st.integers(0, 2**32 - 1), st.integers(1, 80), st.integers(1, 5), st.floats(0.02, 1.0),
       st.sampled_from([1e-6, 0.1, 1.0, 100.0, 1e8]), st.sampled_from(["normal", "duplicates", "constant", "wide"]))
def test_svm_nu_property(seed, n, d, nu, kernel_scale, kind):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, d))
    if kind == "duplicates":
        X = np.repeat(X[: max(1, n // 4)], 4, axis=0)[:n]
    elif kind == "constant":
        X[:] = 3.0
    elif kind == "wide":
        X *= 1e6
    model = _core.fit_one_class_svm(np.ascontiguousarray(X), nu=nu, kernel_scale=kernel_scale)
    n = X.shape[0]
    alpha = np.zeros(n)
    alpha[np.asarray(model.support)] = np.asarray(model.dual_coef)
    assert np.all(np.isfinite(alpha)) and math.isfinite(model.rho)
    # libsvm scaling: 0 <= alpha_i <= 1, sum alpha = nu n.
    assert np.all(alpha >= -1e-12) and np.all(alpha <= 1 + 1e-12)
    assert abs(alpha.sum() - nu * n) <= 1e-6 * n
    # nu-property (Schoelkopf et al.): #{alpha_i = 1} <= nu n <= #{alpha_i > 0}.
    assert np.sum(alpha >= 1 - 1e-9) <= nu * n + 1e-9
    assert np.sum(alpha > 0) >= nu * n - 1e-9
    scores = model.decision_function(np.ascontiguousarray(X))
    assert np.all(np.isfinite(scores))


if __name__ == "__main__":
    raise SystemExit(pytest.main([__file__, "-q"]))
