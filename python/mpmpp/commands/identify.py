"""``mpmpp identify DATA --inputs OP --outputs PV -o MODEL.json``: a model file from routine data."""
from __future__ import annotations


def add_arguments(parser) -> None:
    from ._pair import DATA_HELP, add_data_arguments

    parser.add_argument("data", metavar="DATA", help=DATA_HELP)
    parser.add_argument("--inputs", required=True, metavar="COL[,COL...]", help="input columns (e.g. the OP)")
    parser.add_argument("--outputs", required=True, metavar="COL[,COL...]", help="output columns (e.g. the PV)")
    parser.add_argument("--setpoints", metavar="COL[,COL...]",
                        help="setpoint column per output (default OUTPUT_sp where present); shows the controller's action")
    parser.add_argument("-o", "--output", required=True, metavar="MODEL", help="model file to write (JSON)")
    parser.add_argument("--force", action="store_true", help="replace MODEL if it exists")
    parser.add_argument("--name", help="model name (default: from the data file)")
    parser.add_argument("--max-dead-time", type=float, metavar="SECONDS",
                        help="longest dead time searched (default 600, at most a tenth of the record)")
    parser.add_argument("--process", choices=("auto", "self-regulating", "integrating"), default="auto",
                        help="model class of every channel: chosen by BIC (auto, the default), first order plus "
                             "dead time, or integrating (a level: with or without a lag)")
    parser.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    add_data_arguments(parser)


def run(args) -> int:
    import json
    import os

    from ._pair import load_loop_data_for, note_repairs
    from ..model_identification import loop_columns, model_from_data
    from ..process_class import CLASSES_BY_NAME

    if os.path.exists(args.output) and not args.force:
        raise ValueError(f"{args.output}: exists (add --force to replace it)")
    inputs, outputs, setpoints = loop_columns(args.inputs, args.outputs, args.setpoints)
    data = load_loop_data_for(args, inputs + outputs + (setpoints or []))
    note_repairs(args.data, data.attrs["repairs"])
    name = args.name or f"identified from {os.path.basename(args.data)}"
    result = model_from_data(data, args.inputs, args.outputs, setpoints=args.setpoints, name=name, max_dead_time_s=args.max_dead_time,
                             classes=CLASSES_BY_NAME[args.process])
    result.save(args.output, overwrite=args.force)
    if args.json:
        print(json.dumps({**result.to_dict(), "model": args.output}))
    else:
        print(result.summary())
        print(f"  wrote {args.output}")
    return 0
