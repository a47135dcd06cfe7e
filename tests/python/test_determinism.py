"""Same inputs, same seed -> bit-identical outputs: across separate processes (the simulator,
resampling), repeated fits (SVM, ARX-OE) and thread counts (the SVM's kernel expansion is the
engine's only multi-threaded loop; OMP/OpenBLAS thread counts must not matter either)."""
import hashlib
import subprocess
import sys
import textwrap

import numpy as np

import mpmpp
from mpmpp import _core, identify, scenarios
from child_process import child_env


# Prints one digest of everything random or iterative, computed in a fresh process.
DIGEST = textwrap.dedent("""
    import copy, hashlib, numpy as np, mpmpp
    from mpmpp import identify, scenarios
    h = hashlib.sha256()
    spec = copy.deepcopy(scenarios.paper_siso()); spec["duration_s"] = 2 * 3600.0; spec["events"] = []
    df = mpmpp.simulate(spec, seed=11)
    h.update(np.ascontiguousarray(df.to_numpy()).tobytes())
    rng = np.random.default_rng(3)
    X = rng.normal(size=(300, 6))
    h.update(np.asarray(mpmpp.resample(X, 200, seed=5)).tobytes())
    svm = mpmpp.OneClassSVM(nu=0.1, kernel_scale=6.0).fit(X)
    h.update(np.asarray(svm.decision_function(X)).tobytes())
    y = df["dry_weight"].to_numpy(); u = df["stock_flow"].to_numpy()
    r = identify.arx_oe(y, u, 9, 10, 17, fir_length=60)
    h.update(np.asarray(r.channels[0].fir).tobytes()); h.update(np.asarray(r.noise).tobytes())
    print(h.hexdigest())
""")


def digest_in_child(threads):
    env = child_env(OMP_NUM_THREADS=str(threads), OPENBLAS_NUM_THREADS=str(threads), MKL_NUM_THREADS=str(threads))
    out = subprocess.run([sys.executable, "-c", DIGEST], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout.strip()


def test_bit_identical_across_processes_and_thread_counts():
    one, two = digest_in_child(1), digest_in_child(2)
    assert len(one) == 64 and one == two


def test_svm_fit_twice_and_kernel_threads():
    rng = np.random.default_rng(8)
    X = rng.normal(size=(400, 5))
    a = _core.fit_one_class_svm(X, nu=0.2, kernel_scale=3.0)
    b = _core.fit_one_class_svm(X, nu=0.2, kernel_scale=3.0)
    assert a.rho == b.rho and np.array_equal(a.dual_coef, b.dual_coef) and np.array_equal(a.support, b.support)
    Z = rng.normal(size=(3000, 5))
    scores = [_core.gaussian_kernel_expansion(a.support_vectors, a.dual_coef, 3.0, Z, n_threads=k)
              for k in (1, 2, 3, 8)]
    for s in scores[1:]:
        assert np.array_equal(s, scores[0])


def test_simulate_same_seed_same_data_other_seed_differs():
    import copy
    spec = copy.deepcopy(scenarios.paper_siso())
    spec["duration_s"], spec["events"] = 3600.0, []
    a, b, c = mpmpp.simulate(spec, seed=4), mpmpp.simulate(spec, seed=4), mpmpp.simulate(spec, seed=5)
    assert np.array_equal(a.to_numpy(), b.to_numpy())
    assert not np.array_equal(a["dry_weight"].to_numpy(), c["dry_weight"].to_numpy())


def test_arx_oe_windows_repeatable():
    rng = np.random.default_rng(9)
    u = rng.normal(size=3000)
    y = mpmpp.TransferFunction([0.3], [1.0, -0.8], 2).filter(u) + 0.05 * rng.normal(size=3000)
    runs = [identify.arx_oe_windows(y, u, 500, 250, 4, 4, 2, fir_length=30) for _ in range(2)]
    fir = [np.concatenate([w.result.channels[0].fir for w in r]) for r in runs]
    assert hashlib.sha256(fir[0].tobytes()).digest() == hashlib.sha256(fir[1].tobytes()).digest()
