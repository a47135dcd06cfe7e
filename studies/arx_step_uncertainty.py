"""How much of the spread of a window's FIR estimates comes from the ARX step's A(q)?

Paper MIMO example, output reel_moisture, one 2 h window (ending at --end-h) per seed:
the spread over seeds of ARX-OE's FIR coefficients (A(q) estimated in the window), of the
same least squares on data filtered by the true inverse noise model 1/H33, the OE step's
own covariance sigma^2 (J'J)^-1 (which treats A(q) as exact) and ARX-OE's two-step
covariance (two_step_covariance.hpp: A(q)'s uncertainty carried through). docs/detection.md
uses it.

    python studies/arx_step_uncertainty.py [--seeds 60] [--end-h 15]
"""
from __future__ import annotations

import argparse

import numpy as np
from scipy.signal import lfilter

import mpmpp
from mpmpp import scenarios
from mpmpp.evaluate import nominal_model
from mpmpp.identify import arx_oe_model, channel_inputs

OUTPUT = "reel_moisture"


def fir_least_squares(y, U, model, inputs, lengths, skip=40):
    """FIR coefficients after each nominal delay by ordinary least squares (the OE step's FIR form)."""
    cols = []
    for j, name in enumerate(inputs):
        d = model.process(OUTPUT, name).delay
        for i in range(lengths[j]):
            cols.append(np.r_[np.zeros(d + i), U[:len(y) - d - i, j]])
    Phi = np.array(cols).T[skip:]
    return np.linalg.lstsq(Phi, y[skip:], rcond=None)[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=60)
    ap.add_argument("--end-h", type=float, default=15.0, help="end of the analysed window (h)")
    args = ap.parse_args()
    scenario = scenarios.paper_mimo()
    model = nominal_model(scenario)
    inputs = channel_inputs(model, OUTPUT)
    h = model.noise(OUTPUT)
    window = 1440  # 2 h at 5 s
    end = int(args.end_h * 3600 / model.sample_time_s)
    estimated, true_filter, oe_sd, two_step_sd = [], [], [], []
    for seed in range(args.seeds):
        data = mpmpp.simulate(scenario, seed=seed).iloc[end - window:end]
        r = arx_oe_model(model, data, OUTPUT, na=18, nb=11, structure="fir", two_step_covariance=True)
        lengths = [len(c.fir) - model.process(OUTPUT, name).delay for c, name in zip(r.channels, inputs)]
        y = data[OUTPUT].to_numpy() - data[OUTPUT].mean()
        U = data[inputs].to_numpy() - data[inputs].to_numpy().mean(axis=0)
        # A0 = 1/H: filter by H's denominator over its numerator.
        yf, Uf = lfilter(h.den, h.num, y), lfilter(h.den, h.num, U, axis=0)
        estimated.append(np.asarray(r.oe.theta))
        true_filter.append(fir_least_squares(yf, Uf, model, inputs, lengths))
        oe_sd.append(np.sqrt(np.diag(np.asarray(r.oe.covariance))))
        two_step_sd.append(np.sqrt(np.diag(np.asarray(r.two_step_covariance))))
    labels = [f"{name}[{i}]" for name, L in zip(inputs, lengths) for i in range(L)]
    print(f"{OUTPUT}, window ending at {args.end_h:g} h, {args.seeds} seeds: sd of each FIR coefficient")
    print(f"{'coefficient':22s} {'ARX-OE (A estimated)':>21s} {'true 1/H filter':>16s} {'OE covariance':>14s} "
          f"{'two-step covariance':>20s}")
    for k, label in enumerate(labels):
        print(f"{label:22s} {np.std(estimated, axis=0)[k]:21.5f} {np.std(true_filter, axis=0)[k]:16.5f} "
              f"{np.mean(oe_sd, axis=0)[k]:14.5f} {np.mean(two_step_sd, axis=0)[k]:20.5f}")


if __name__ == "__main__":
    main()
