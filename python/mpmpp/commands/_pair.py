"""Reading the model + data pair every analysis command takes (through the foundation's IO)."""
from __future__ import annotations


def load_pair(model_path: str, data_path: str):
    import mpmpp

    model = mpmpp.load_model(model_path)
    return model, mpmpp.load_data(data_path, model)


def add_pair_arguments(parser) -> None:
    parser.add_argument("model", metavar="MODEL", help="nominal model file (JSON, formats.md)")
    parser.add_argument("data", metavar="DATA", help="operating data (CSV, formats.md)")
    parser.add_argument("--out", metavar="DIR", help="write PNG figures and tables here")
    parser.add_argument("--json", action="store_true", help="print one JSON document on stdout")


def report(result, args, name: str) -> int:
    """The shared output of the pair commands: ``--out DIR`` gets the figures and ``NAME.json``
    (written atomically), stdout gets the JSON document (``--json``) or the summary."""
    import json
    from pathlib import Path

    from ..io import atomic_output

    if args.out:
        paths = result.plot(args.out)
        with atomic_output(Path(args.out) / f"{name}.json") as f:
            f.write(json.dumps(result.to_dict(), indent=1))
    if args.json:
        print(json.dumps(result.to_dict()))
    else:
        print(result.summary())
        if args.out:
            print(f"  figures: {', '.join(str(p) for p in paths)}")
    return 0
