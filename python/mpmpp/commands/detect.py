"""``mpmpp detect MODEL DATA --train-end WHEN``: moving-window MPM and noise-change detection."""
from __future__ import annotations

import json
import os

from ._pair import add_pair_arguments, add_train_end_argument, load_pair, result_document, train_end


def add_arguments(parser) -> None:
    add_pair_arguments(parser, outputs=False)
    add_train_end_argument(parser,
                           help_text="end of the training period: windows ending by then train the detector "
                                     "(the data must be free of mismatch there); default: the preset's training, "
                                     "at most half the record")
    parser.add_argument("--config", metavar="FILE",
                        help="detector config JSON ({\"preset\": \"paper_siso\", \"alpha\": 2, ...}); "
                             "or a preset name (siso, mimo, paper_siso, paper_mimo); default: the recommended preset (siso or mimo) for the model's size. "
                             "A preset's durations are resolved at the data's sample time (whole samples, a minimum number of "
                             "samples per window; a note says so, docs/detection.md); values the file sets are used as given")
    parser.add_argument("--out", metavar="DIR", help="write scores/indicator plots (PNG) and detect.json there")
    parser.add_argument("--json", action="store_true", help="print one JSON document (docs/formats.md detect --json)")
    parser.add_argument("--save-detector", metavar="FILE",
                        help="save the trained detector (versioned JSON) to monitor new data later")


def run(args) -> int:
    from ..detect import detect, make_config
    from ..io import atomic_output
    from ..noise_alarm_check import check_noise_alarms
    from ..preset_timing import span_text

    model, data, clock = load_pair(args)
    # The detector counts its training period from the first sample.
    trained_s = None if args.train_end is None else clock.when(args.train_end) - clock.start_s
    config = make_config(args.config, model, clock.duration_s, trained_s)
    window_s = config.window_samples(model.sample_time_s) * model.sample_time_s
    train_end(args, clock, window_s, "monitoring (one detection window)")  # refuses one that leaves no window
    result, detector = detect(model, data, trained_s, args.config, return_detector=True)
    if args.save_detector:
        detector.save(args.save_detector)
    checks = check_noise_alarms(model, data, result)
    result.notes += [c.note(clock.stamp) for c in checks]
    doc = result_document(result, clock)
    if checks:
        doc["noise_alarm_checks"] = clock.stamp_fields([c.to_dict() for c in checks])
    if args.out:
        from ..detect_plots import plot_detection
        from ..timeaxis import origin_of

        os.makedirs(args.out, exist_ok=True)
        with atomic_output(os.path.join(args.out, "detect.json")) as f:
            json.dump(doc, f, indent=1)
        plot_detection(result, os.path.join(args.out, "detection.png"), origin=origin_of(data))
    if args.json:
        print(json.dumps(doc))
    else:
        end = clock.start_s + result.train_end_s
        print(f"trained on {clock.span_between(clock.start_s, end)}, {len(result.windows)} windows of "
              f"{span_text(window_s)} every {span_text(detector.config.step_s)}, threshold s_T = {result.threshold:g}")
        print(result.alarm_table(clock.stamp))
    return 0
