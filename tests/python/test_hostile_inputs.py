"""Hostile inputs to the Python API (not files: those are in test_bad_inputs.py).

Every row of HOSTILE is one call with a malformed argument -- wrong shape, NaN/inf, empty,
wrong dtype, non-contiguous, huge order, window longer than the data -- and what it must
give: an exception of the named type whose message contains the fragment, or ("flag", expr)
for a result that is returned but flagged (expr, evaluated on `result`, must be true).

The rows run in a child process (all in one, to pay the import once), with an address-space
limit so a hostile allocation fails instead of swapping the machine. A segfault or abort
in the C++ engine therefore fails that row with the signal instead of killing pytest; the
rows after it run in a fresh child.
"""
import json
import subprocess
import sys
import textwrap

import pytest
from child_process import child_env

# Names every row may use (built once in the child).
PRELUDE = textwrap.dedent("""
    import numpy as np, pandas as pd, mpmpp
    from mpmpp import _core, identify
    TF = mpmpp.TransferFunction
    rng = np.random.default_rng(7)
    y200, u200 = rng.normal(size=200), rng.normal(size=200)
    X50 = rng.normal(size=(50, 2))
    MODEL = mpmpp.Model("m", 1.0, ["u"], ["y"], {"y": {"u": TF([0.5], [1.0, -0.5], 1)}})
    def with_nan(x, k=5):
        x = np.array(x, dtype=float); x.flat[k] = np.nan; return x
    def tuning(**changes):
        t = _core.MpcTuning(); t.move_weight = [1.0]; t.cv_target = [0.0]; t.mv_target = [0.0]
        t.cv_target_weight = [1.0]; t.mv_target_weight = [0.0]
        for k, v in changes.items():
            setattr(t, k, v)
        return t
    def scenario(**changes):
        import copy
        spec = copy.deepcopy(mpmpp.scenarios.paper_siso()); spec["events"] = []; spec["duration_s"] = 100.0
        spec.update(changes)
        return spec
    def model_json(**noise):
        import json
        return json.dumps({"sample_time_s": 1, "inputs": ["u"], "outputs": ["y"], "process": {},
                           "noise": {"y": noise}})
""")

BIG = 2**31 - 1  # the largest C int: overflowed index arithmetic before the order limits

# (what, call, expected): expected is (exception type name, message fragment) or ("flag", expr)
HOSTILE = [
    # TransferFunction
    ("TF: NaN numerator", "TF([np.nan], [1.0])", ("ValueError", "num has a non-finite coefficient")),
    ("TF: inf denominator", "TF([1.0], [1.0, np.inf])", ("ValueError", "den has a non-finite coefficient")),
    ("TF: empty numerator", "TF(np.zeros(0), [1.0])", ("ValueError", "num must have at least one coefficient")),
    ("TF: den[0] = 0", "TF([1.0], [0.0, 1.0])", ("ValueError", "den[0] must be non-zero")),
    ("TF: negative delay", "TF([1.0], [1.0], -1)", ("ValueError", "delay must be >= 0")),
    ("TF: huge delay", f"TF([1.0], [1.0], {BIG})", ("ValueError", "delay must be <= 1000000")),
    ("TF: series of two huge delays (int overflow)", "TF([1.], [1.], 1000000).series(TF([1.], [1.], 1000000))",
     ("ValueError", "series delay must be <= 1000000")),
    ("TF: 2-D numerator (wrong shape)", "TF(np.ones((2, 2)), [1.0])", ("TypeError", "incompatible constructor arguments")),
    ("TF: string coefficients (wrong dtype)", "TF(['a'], [1.0])", ("TypeError", "incompatible constructor arguments")),
    ("TF: negative response length", "TF([1.], [1.]).impulse(-5)", ("ValueError", "response length must be >= 0")),
    ("TF: FOPTD with NaN gain", "TF.from_foptd(np.nan, 1, 0, 1)", ("ValueError", "gain must be finite")),
    ("TF: FOPTD dead time of 1e12 samples", "TF.from_foptd(1, 1, 1e12, 1)", ("ValueError", "dead_time_s must be at most 1e6")),
    ("TF: filter with NaN input propagates NaN (flagged, not hidden)",
     "TF([1.], [1., -0.5]).filter([1.0, np.nan, 1.0])", ("flag", "np.isnan(result[1:]).all() and result[0] == 1")),
    ("TF: filter of a non-contiguous view", "TF([1.], [1., -0.5]).filter(np.arange(20.)[::3])",
     ("flag", "np.allclose(result, __import__('scipy.signal', fromlist=['lfilter']).lfilter([1.], [1., -0.5], np.arange(20.)[::3]))")),
    ("TF: filter of an empty signal", "TF([1.], [1., -0.5]).filter(np.zeros(0))", ("flag", "result.shape == (0,)")),
    # Model (constructed in Python, not from a file)
    ("Model: NaN sample time", "mpmpp.Model('m', np.nan, ['u'], ['y'])", ("ValueError", "sample_time_s: must be > 0 and finite")),
    ("Model: duplicate input names", "mpmpp.Model('m', 1.0, ['u', 'u'], ['y'])", ("ValueError", 'inputs[1]: duplicate name "u"')),
    ("Model: unknown output in process", "mpmpp.Model('m', 1.0, ['u'], ['y'], {'z': {'u': TF()}})",
     ("ValueError", 'process.z: unknown output "z"')),
    ("Model: unstable noise model", "mpmpp.Model('m', 1.0, ['u'], ['y'], noise={'y': TF([1.], [1., -1.5])})",
     ("ValueError", "noise.y: unstable")),
    ("Model JSON: number overflow 1e400", "mpmpp.Model.from_json('{\"sample_time_s\": 1e400}')",
     ("ValueError", "not valid JSON: number overflow")),
    ("Model JSON: 5000-coefficient noise model (would stall the root finder)",
     "mpmpp.Model.from_json(model_json(num=[1.0] + [0.0] * 5000, den=[1.0] + [1e-4] * 5000))",
     ("ValueError", "noise.y: at most 200 coefficients")),
    ("Model JSON: 100000-deep nesting", "mpmpp.Model.from_json('[' * 100000 + ']' * 100000)",
     ("ValueError", "top level: must be an object")),
    ("Model JSON: NUL bytes", "mpmpp.Model.from_json('\\x00\\x00')", ("ValueError", "not valid JSON")),
    # Data tables
    ("DataTable: values rows != time samples", "_core.DataTable([0., 1.], ['a'], np.ones((3, 1)))",
     ("ValueError", "values: shape 3x1, expected 2 samples x 1 columns")),
    ("DataTable: NaN time", "_core.DataTable([0., np.nan], ['a'], np.ones((2, 1)))", ("ValueError", "time: must be finite")),
    ("save_data: text column", "mpmpp.save_data('unused.csv', pd.DataFrame({'time': [0., 1.], 'a': ['x', 'y']}))",
     ("ValueError", "every column must be numeric")),
    # QP
    ("QP: NaN in P", "mpmpp.solve_qp(np.array([[np.nan]]), [1.], np.eye(1), [0.], [1.])", ("ValueError", "P has a NaN or infinite entry")),
    ("QP: q of the wrong length", "mpmpp.solve_qp(np.eye(2), [1.], np.eye(2), [0., 0], [1., 1])", ("ValueError", "q has 1 entries, expected 2")),
    ("QP: l > u", "mpmpp.solve_qp(np.eye(2), [1., 1], np.eye(2), [1., 1], [0., 0])", ("ValueError", "l[0] > u[0]")),
    ("QP: NaN bound", "mpmpp.solve_qp(np.eye(2), [1., 1], np.eye(2), [np.nan, 0], [1., 1])", ("ValueError", "l[0] is NaN")),
    ("QP: non-symmetric P", "mpmpp.solve_qp(np.array([[1., 2], [0, 1]]), [1., 1], np.eye(2), [0., 0], [1., 1])",
     ("ValueError", "P must be symmetric")),
    ("QP: indefinite P is flagged", "mpmpp.solve_qp(-np.eye(2), [1., 1], np.eye(2), [0., 0], [1., 1])",
     ("flag", "result.status == 'non_convex'")),
    ("QP: iteration limit 0 is flagged", "mpmpp.solve_qp(np.eye(2), [1., 1], np.eye(2), [0., 0], [1., 1], max_iterations=0)",
     ("flag", "result.status == 'max_iterations'")),
    ("QP: non-contiguous Fortran-order P", "mpmpp.solve_qp(np.asfortranarray(4 * np.eye(4))[::2, ::2], [-4., 8], np.eye(2), [-1., -1], [1., 1])",
     ("flag", "result.status == 'solved' and np.allclose(result.x, [1., -1.])")),
    # ARX / OE / ARX-OE
    ("ARX: NaN in y", "identify.arx(with_nan(y200), u200, 2, 2, 1)", ("RuntimeError", "y has 1 non-finite samples of 200")),
    ("ARX: 2-D y", "identify.arx(np.ones((10, 2)), np.ones(10), 2, 2, 1)", ("ValueError", "y must be 1-D")),
    ("ARX: empty data", "identify.arx(np.zeros(0), np.zeros(0), 2, 2, 1)", ("RuntimeError", "window too short for the ARX orders: 0 samples")),
    ("ARX: u rows != y samples", "identify.arx(np.zeros(10), np.zeros(11), 2, 2, 1)", ("ValueError", "u must have 10 rows")),
    ("ARX: NaN delta", "identify.arx(y200, u200, 2, 2, 1, delta=np.nan)", ("ValueError", "delta must be >= 0")),
    ("ARX: delay 2^31-1 (was a segfault)", f"identify.arx(y200, u200, 2, 2, {BIG})", ("ValueError", "delays[0] must be <= 1000000")),
    ("ARX: na 10^9 (was a multi-GB allocation)", "identify.arx(y200, u200, 10**9, 2, 1)", ("ValueError", "na must be <= 1000000")),
    ("ARX: nb 2^31-1", f"identify.arx(y200, u200, 2, {BIG}, 0)", ("ValueError", "nb[0] must be <= 1000000")),
    ("ARX: order larger than the window", "identify.arx(y200, u200, 150, 2, 1)", ("RuntimeError", "window too short for the ARX orders")),
    ("OE: nb = nf = 2^31-1 (int overflow)", f"identify.oe(y200, u200, 1, 'oe', nb={BIG}, nf={BIG})", ("ValueError", "channels[0].nb must be <= 1000000")),
    ("OE: negative skip", "identify.oe(y200, u200, 1, skip=-1)", ("ValueError", "skip must be >= 0")),
    ("OE: NaN pole radius", "identify.oe(y200, u200, 1, max_pole_radius=np.nan)", ("ValueError", "max_pole_radius must be in (0, 1)")),
    ("ARX-OE: fir_length 2^31-1 (was a double free after bad_alloc)", f"identify.arx_oe(y200, u200, 2, 2, 1, fir_length={BIG})",
     ("ValueError", "fir_length[0] must be in [1, 1000000]")),
    ("ARX-OE: empty window (was max of an empty vector)", "identify.arx_oe(np.zeros(0), np.zeros(0), 2, 2, 1)",
     ("RuntimeError", "y has no samples")),
    ("ARX-OE: constant input", "identify.arx_oe(y200, np.ones(200), 2, 2, 1)", ("RuntimeError", "u[0] is constant over the window")),
    ("ARX-OE: unknown detrend", "identify.arx_oe(y200, u200, 2, 2, 1, detrend='x')", ("ValueError", "detrend must be 'none', 'mean' or 'linear'")),
    ("ARX-OE windows: window longer than the data", "identify.arx_oe_windows(y200, u200, 500, 10, 2, 2, 1)", ("flag", "result == []")),
    ("ARX-OE windows: window 0", "identify.arx_oe_windows(y200, u200, 0, 10, 2, 2, 1)", ("ValueError", "window must be >= 1 sample")),
    ("ARX-OE windows: NaN gap flags only its window",
     "identify.arx_oe_windows(with_nan(np.r_[y200, y200], 250), np.r_[u200, u200], 100, 100, 2, 2, 1)",
     ("flag", "[w.ok for w in result] == [True, True, False, True] and 'non-finite' in result[2].message")),
    ("FIR length of an unstable nominal", "identify.fir_length_to_one_percent(TF([1.], [1., -1.01]))",
     ("ValueError", "does not fall below 1% of its peak")),
    # One-class SVM and resampling
    ("SVM: NaN in X", "mpmpp.OneClassSVM().fit(with_nan(X50))", ("ValueError", "NaN")),
    ("SVM: empty X", "mpmpp.OneClassSVM().fit(np.zeros((0, 2)))", ("ValueError", "0 sample(s)")),
    ("SVM: 3-D X", "mpmpp.OneClassSVM().fit(np.zeros((5, 2, 2)))", ("ValueError", "dim 3")),
    ("SVM: nu = 0", "mpmpp.OneClassSVM(nu=0).fit(X50)", ("ValueError", "nu: must be a number in (0, 1]")),
    ("SVM: NaN kernel scale", "mpmpp.OneClassSVM(kernel_scale=np.nan).fit(X50)", ("ValueError", "kernel_scale: must be a finite number > 0")),
    ("SVM: predict with the wrong feature count", "mpmpp.OneClassSVM().fit(X50).predict(np.zeros((3, 3)))", ("ValueError", "X has 3 features")),
    ("SVM engine: NaN in X", "_core.fit_one_class_svm(np.full((5, 2), np.nan))", ("ValueError", "X: contains NaN or infinite values")),
    ("SVM engine: cache 0 MB", "_core.fit_one_class_svm(X50, cache_mb=0)", ("ValueError", "cache_mb: must be a finite number > 0")),
    ("SVM engine: non-contiguous X equals its copy",
     "(_core.fit_one_class_svm(np.asarray(X50)[::2]).rho, _core.fit_one_class_svm(np.ascontiguousarray(np.asarray(X50)[::2])).rho)",
     ("flag", "result[0] == result[1]")),
    ("kernel expansion: coef length != support vectors", "_core.gaussian_kernel_expansion(np.ones((3, 2)), np.ones(2), 1.0, np.ones((4, 2)))",
     ("ValueError", "coef: length 2 does not match 3 support vectors")),
    ("resample: one training window", "mpmpp.resample(np.ones((1, 2)), 5)", ("ValueError", "need at least 2 training windows")),
    ("resample: NaN feature", "mpmpp.resample(with_nan(X50), 5)", ("ValueError", "features: contains NaN or infinite values")),
    ("resample: NaN alpha", "mpmpp.resample(X50, 5, alpha=np.nan)", ("ValueError", "alpha: width factor must be a finite number")),
    ("resample: n = 0", "mpmpp.resample(X50, 0)", ("ValueError", "n: number of synthetic models must be >= 1")),
    # MPC and closed-loop simulation
    ("MPC: initial inputs of the wrong length", "_core.Mpc(MODEL, tuning(), np.zeros(3))", ("ValueError", "initial inputs must be 1 finite values")),
    ("MPC: NaN measurement", "_core.Mpc(MODEL, tuning(), np.zeros(1)).step(np.array([np.nan]))", ("ValueError", "NaN or infinite")),
    ("MPC: measurement of the wrong length", "_core.Mpc(MODEL, tuning(), np.zeros(1)).step(np.zeros(4))", ("ValueError", "measured outputs must have 1 entries")),
    ("MPC: prediction horizon 10^9 (was bad_alloc)", "_core.Mpc(MODEL, tuning(prediction_horizon=10**9), np.zeros(1))",
     ("ValueError", "prediction_horizon must be <= 10000")),
    ("MPC: control horizon 10^4 (a 10^4 x 10^4 dense QP)", "_core.Mpc(MODEL, tuning(prediction_horizon=10**4, control_horizon=10**4), np.zeros(1))",
     ("ValueError", "control_horizon x inputs must be <= 2000")),
    ("MPC: NaN move weight", "_core.Mpc(MODEL, tuning(move_weight=[np.nan]), np.zeros(1))", ("ValueError", "move_weight[0] must be finite")),
    ("simulate: duration of 1e13 s (was a TypeError from the binding)", "mpmpp.simulate(scenario(duration_s=1e13))",
     ("ValueError", "duration_s: gives 2000000000000 samples")),
    ("simulate: seed 2^70", "mpmpp.simulate(scenario(), seed=2**70)", ("ValueError", "seed: must be < 2^63")),
    ("simulate: negative seed", "mpmpp.simulate(scenario(), seed=-1)", ("ValueError", "seed: must be >= 0")),
    ("simulate: unknown scenario key", "mpmpp.simulate(scenario(bogus=1))", ("ValueError", "bogus: unknown key")),
    ("simulate: empty engine config", "_core.simulate_closed_loop(_core.ClosedLoopConfig())", ("ValueError", "duration must give at least one sample")),
]

# pybind11's TypeError lists the accepted signatures, and scikit-learn's input validation
# (OneClassSVM is a scikit-learn estimator) explains NaN over several lines: both stay as is.
SKLEARN_MESSAGES = {"SVM: NaN in X"}

# The child: runs rows given as JSON on stdin, one JSON line per finished row; "start" lines
# tell the parent which row was running if the process dies.
ROW_SECONDS = 60
CHILD = f"ROW_SECONDS = {ROW_SECONDS}\n" + PRELUDE + textwrap.dedent("""
    import faulthandler, json, os, resource, sys
    resource.setrlimit(resource.RLIMIT_AS, (8 << 30, 8 << 30))
    os.chdir(sys.argv[1])
    for name, call, expected in json.load(sys.stdin):
        print(json.dumps({"start": name}), flush=True)
        faulthandler.dump_traceback_later(ROW_SECONDS, exit=True)  # a hang ends the child: that row fails
        try:
            result = eval(call)
            out = {"name": name, "returned": True}
            if expected[0] == "flag":
                out["flag_ok"] = bool(eval(expected[1]))
        except Exception as exc:
            out = {"name": name, "returned": False, "type": type(exc).__name__, "message": str(exc)}
        faulthandler.cancel_dump_traceback_later()
        print(json.dumps(out), flush=True)
""")


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory):
    env = child_env()
    workdir = str(tmp_path_factory.mktemp("hostile"))
    todo = [list(row) for row in HOSTILE]
    results = {}
    while todo:
        proc = subprocess.run([sys.executable, "-c", CHILD, workdir], input=json.dumps(todo),
                              capture_output=True, text=True, env=env)
        running = None
        for line in proc.stdout.splitlines():
            record = json.loads(line)
            if "start" in record:
                running = record["start"]
            else:
                results[record["name"]] = record
                running = None
        done = {row[0] for row in todo if row[0] in results}
        if running is not None:  # the child died inside this row
            results[running] = {"name": running, "died": proc.returncode, "stderr": proc.stderr[-2000:]}  # crash or hang
            done.add(running)
        elif proc.returncode != 0:
            pytest.fail(f"hostile-input child failed outside a row: {proc.stderr[-2000:]}")
        todo = [row for row in todo if row[0] not in done]
    return results


def test_table_is_large_and_unique():
    assert len(HOSTILE) >= 30
    assert len({row[0] for row in HOSTILE}) == len(HOSTILE)


@pytest.mark.parametrize("what,call,expected", HOSTILE, ids=[row[0] for row in HOSTILE])
def test_hostile_input(outcomes, what, call, expected):
    got = outcomes[what]
    assert "died" not in got, f"{call} killed the process (exit {got.get('died')}): {got.get('stderr')}"
    if expected[0] == "flag":
        assert got["returned"], f"{call} raised {got.get('type')}: {got.get('message')}"
        assert got["flag_ok"], f"{call}: flag check {expected[1]!r} is false"
    else:
        kind, fragment = expected
        assert not got["returned"], f"{call} returned instead of raising {kind}"
        assert got["type"] == kind, f"{call} raised {got['type']}: {got['message']}"
        assert fragment in got["message"], f"{call}: {got['message']!r} lacks {fragment!r}"
        if kind != "TypeError" and what not in SKLEARN_MESSAGES:
            assert "\n" not in got["message"], f"{call}: the message is not one line: {got['message']!r}"
