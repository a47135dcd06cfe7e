"""``mpmpp detect MODEL DATA --train-end SECONDS``: moving-window MPM and noise-change detection."""
from __future__ import annotations

import json
import os


def add_arguments(parser) -> None:
    parser.add_argument("model", help="nominal model file (JSON, FORMATS.md)")
    parser.add_argument("data", help="routine operating data (CSV, FORMATS.md)")
    parser.add_argument("--train-end", type=float, required=True, metavar="SECONDS",
                        help="end of the training period, seconds after the first sample; windows ending "
                             "by then train the detector (the data must be free of mismatch there)")
    parser.add_argument("--config", metavar="FILE",
                        help="detector config JSON ({\"preset\": \"paper_siso\", \"alpha\": 2, ...}); "
                             "or a preset name (siso, mimo, paper_siso, paper_mimo); default: the recommended preset (siso or mimo) for the model's size")
    parser.add_argument("--out", metavar="DIR", help="write scores/indicator plots (PNG) and detect.json there")
    parser.add_argument("--json", action="store_true", help="print one JSON document (FORMATS.md detect --json)")
    parser.add_argument("--save-detector", metavar="FILE",
                        help="save the trained detector (versioned JSON) to monitor new data later")


def run(args) -> int:
    from .. import load_data, load_model
    from ..detect import detect

    model = load_model(args.model)
    data = load_data(args.data, model)
    result, detector = detect(model, data, args.train_end, args.config, return_detector=True)
    if args.save_detector:
        detector.save(args.save_detector)
    if args.out:
        from ..detect_plots import plot_detection

        os.makedirs(args.out, exist_ok=True)
        result.save_json(os.path.join(args.out, "detect.json"))
        plot_detection(result, os.path.join(args.out, "detection.png"))
    if args.json:
        print(json.dumps(result.to_dict()))
    else:
        print(f"trained on {args.train_end / 3600:.2f} h, {len(result.windows)} windows, "
              f"threshold s_T = {result.threshold:g}")
        print(result.alarm_table())
    return 0
