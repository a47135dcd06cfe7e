"""The paper examples under another controller, other tunings and other noise.

An outside check of the recommended presets on the Section 5 scenarios made different in the
ways an independent simulator makes them: the MPC's first move clipped after an unconstrained
plan (as a DMC does), a ten times larger move weight, and other disturbance colours (AR(2),
white; AR(1) 0.8 on every MIMO output), with the presets' training and the paper's (3 h / 4 h).
Nothing was chosen on these runs (docs/detection.md "The paper examples under other
controllers and noise" says which seeds were looked at).

    python studies/paper_variants.py --seeds 20 --first-seed 700 [--variants siso:clip,mimo:clip_ar1]
"""
import argparse

from mpmpp import scenarios
from mpmpp.evaluate import evaluate, format_table

VARIANTS = ("siso:clip", "siso:clip_mw", "siso:clip_ar2", "siso:clip_white", "mimo:clip", "mimo:clip_ar1")


def scenario(variant: str) -> dict:
    """'siso:' or 'mimo:' and the changes joined by '_': clip, mw (move weight x10), ar2, white, ar1."""
    size, _, changes = variant.partition(":")
    s = scenarios.paper_siso() if size == "siso" else scenarios.paper_mimo()
    changes = set(changes.split("_"))
    unknown = changes - {"clip", "mw", "ar2", "white", "ar1"}
    if size not in ("siso", "mimo") or unknown:
        raise SystemExit(f"--variants: unknown variant {variant!r}")
    s["controller"]["clip_moves"] = "clip" in changes
    if "mw" in changes:
        for mv in s["controller"]["mv"].values():
            mv["move_weight"] *= 10.0
    colour = {"ar2": ([1.0], [1.0, -1.2, 0.5]), "white": ([1.0], [1.0]), "ar1": ([1.0], [1.0, -0.8])}
    for name, (num, den) in colour.items():
        if name in changes:
            s["noise"] = {y: scenarios.tf_spec(num, den) for y in s["noise"]}
    s["name"] = f"{s['name']}, {variant}"
    return s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=700)
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--paper-training", action="store_true", help="train on 3 h (SISO) / 4 h (MIMO)")
    ap.add_argument("--workers", type=int, default=None)
    args = ap.parse_args()
    for variant in args.variants.split(","):
        preset = "siso" if variant.startswith("siso") else "mimo"
        config = {"preset": preset}
        if args.paper_training:
            config["train_duration_s"] = (3.0 if preset == "siso" else 4.0) * 3600.0
        summary = evaluate(scenario(variant), range(args.first_seed, args.first_seed + args.seeds), config,
                           workers=args.workers, progress=False)
        print(format_table(summary), "\n", flush=True)


if __name__ == "__main__":
    main()
