#pragma once
// Detection results as files, one writer for every front end (mpmpp detect, the Python API,
// plant-side programs such as cpp/examples/stream_csv.cpp). Written atomically (temporary
// file + rename): a reader never sees half a file.
//   * JSON: docs/formats.md "detect --json": train_end_s, channels, windows (scores and indicator
//     of every window not skipped), alarms, threshold, skipped_windows (with the reason);
//   * alarms CSV: kind,output,input,start_s, one row per alarm start (start_s to the
//     millisecond, times are whole samples);
//   * scores CSV: window,start_s,end_s,score_<k>...,indicator_<k>..., one row per window
//     (empty score cells for skipped windows), numbers in shortest round-trip form.
// `window` is the window's index since the series' first sample (first sample / step).
#include <string>

#include "mpmpp/detector.hpp"

namespace mpmpp {

// indent < 0: one line.
std::string detection_json(const Detector& detector, const DetectionResult& result,
                           int indent = -1);
std::string detection_alarms_csv(const Detector& detector, const DetectionResult& result);
std::string detection_scores_csv(const Detector& detector, const DetectionResult& result);

void save_detection_json(const std::string& path, const Detector& detector,
                         const DetectionResult& result, int indent = 1);
void save_detection_alarms_csv(const std::string& path, const Detector& detector,
                               const DetectionResult& result);
void save_detection_scores_csv(const std::string& path, const Detector& detector,
                               const DetectionResult& result);

}  // namespace mpmpp
