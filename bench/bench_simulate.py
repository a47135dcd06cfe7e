"""Whole closed-loop runs: mpmpp's C++ simulator against a plain NumPy/SciPy loop of the same
controller (tests/python/reference_mpc.py: same condensed QP, solved with quadprog; plant
and noise filters kept as scipy.signal.lfilter states).

    python bench/bench_simulate.py [--repeat N]

Both loops run the paper's SISO scenario without its events (the NumPy loop has no event
support; the events cost nothing per sample in mpmpp) for the full 10,800 samples.
"""
import argparse
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "python"), str(ROOT / "tests" / "python")]

import mpmpp  # noqa: E402
from mpmpp import _core, scenarios  # noqa: E402
from mpmpp.scenario import parse_scenario  # noqa: E402
from reference_mpc import NumpyMpc, closed_loop  # noqa: E402
from timing import best_of  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    spec = scenarios.paper_siso()
    spec["events"] = []
    sc = parse_scenario(spec)
    cfg = sc.to_config()
    n = sc.num_samples
    t_cpp, res = best_of(lambda: _core.simulate_closed_loop(cfg), args.repeat)

    t = sc.tuning
    g = ([0.1003], [1.0, -0.9048], 17)
    h = ([1.0, -0.3], [1.0, 0.6], 0)

    def numpy_run():
        ref = NumpyMpc([[g]], t.prediction_horizon, t.control_horizon, t.cv_target, t.mv_target,
                       t.cv_target_weight, t.mv_target_weight, t.move_weight, t.deviation_weight,
                       t.mv_min, t.mv_max, t.mv_max_move, t.mv_target)
        return closed_loop(None, [[g]], [h], sc.sigma, t.cv_target, 0, n, ref)

    t_np, (U, Y) = best_of(numpy_run, 1)
    # same controller, different noise draws: the loops must behave alike
    assert abs(Y[:, 0].std() / res.y[:, 0].std() - 1) < 0.1

    t_full, _ = best_of(lambda: mpmpp.simulate(scenarios.paper_siso()), args.repeat)
    t_mimo, _ = best_of(lambda: mpmpp.simulate(scenarios.paper_mimo()), 1)
    print(f"paper SISO closed loop, {n} samples, Hp={t.prediction_horizon}, Hc={t.control_horizon}")
    print(f"  mpmpp C++ simulator        {t_cpp * 1e3:9.1f} ms  ({t_cpp / n * 1e6:.2f} us/sample)")
    print(f"  NumPy/SciPy + quadprog     {t_np * 1e3:9.1f} ms  ({t_np / n * 1e6:.2f} us/sample)")
    print(f"  ratio NumPy / mpmpp        {t_np / t_cpp:9.1f} x")
    print(f"  mpmpp.simulate(paper_siso()) with events, to a DataFrame: {t_full * 1e3:.1f} ms")
    print(f"  mpmpp.simulate(paper_mimo()), 20,700 samples:             {t_mimo * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
