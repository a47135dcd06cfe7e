#include "mpmpp/detector_io.hpp"

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "text_file.hpp"

namespace mpmpp {

using ordered_json = nlohmann::ordered_json;

namespace {

bool is_process(const MonitoredChannel& c) { return c.kind == MonitoredChannel::Kind::Process; }

ordered_json channel_json(const Model& model, const MonitoredChannel& c) {
  ordered_json j{{"kind", is_process(c) ? "process" : "noise"},
                 {"output", model.outputs[c.output]}};
  if (is_process(c)) j["input"] = model.inputs[c.input];
  if (!c.in_model) j["in_model"] = false;  // DetectorConfig::absent_channels
  return j;
}

// JSON's number form (shortest round trip, "0.0" for zero), as Python's repr writes it.
std::string csv_number(double v) { return std::isnan(v) ? std::string() : ordered_json(v).dump(); }

ordered_json row(const Eigen::MatrixXd& m, Eigen::Index r) {
  ordered_json a = ordered_json::array();
  for (Eigen::Index k = 0; k < m.cols(); ++k) a.push_back(m(r, k));
  return a;
}

}  // namespace

std::string detection_json(const Detector& detector, const DetectionResult& result, int indent) {
  const Model& model = detector.model();
  ordered_json channels = ordered_json::array(), windows = ordered_json::array(),
               alarms = ordered_json::array(), skipped = ordered_json::array();
  for (const MonitoredChannel& c : result.channels) channels.push_back(channel_json(model, c));
  for (std::size_t w = 0; w < result.windows.size(); ++w) {
    const FeatureWindow& fw = result.windows[w];
    const auto r = static_cast<Eigen::Index>(w);
    if (fw.skipped)
      skipped.push_back({{"start_s", fw.start_s}, {"end_s", fw.end_s}, {"reason", fw.skip_reason}});
    else
      windows.push_back({{"start_s", fw.start_s},
                         {"end_s", fw.end_s},
                         {"scores", row(result.scores, r)},
                         {"indicator", row(result.indicator, r)}});
  }
  for (const DetectionAlarm& a : result.alarms) {
    ordered_json j = channel_json(model, result.channels[a.channel]);
    j["start_s"] = a.start_s;
    alarms.push_back(std::move(j));
  }
  const ordered_json doc{{"train_end_s", detector.train_end_s()},
                         {"channels", channels},
                         {"windows", windows},
                         {"alarms", alarms},
                         {"threshold", detector.config().threshold},
                         {"skipped_windows", skipped}};
  return doc.dump(indent) + (indent >= 0 ? "\n" : "");
}

std::string detection_alarms_csv(const Detector& detector, const DetectionResult& result) {
  const Model& model = detector.model();
  std::string out = "kind,output,input,start_s\n";
  for (const DetectionAlarm& a : result.alarms) {
    const MonitoredChannel& c = result.channels[a.channel];
    char start[64];
    std::snprintf(start, sizeof start, "%.3f", a.start_s);
    out += std::string(is_process(c) ? "process" : "noise") + "," + model.outputs[c.output] + "," +
           (is_process(c) ? model.inputs[c.input] : std::string()) + "," + start + "\n";
  }
  return out;
}

std::string detection_scores_csv(const Detector& detector, const DetectionResult& result) {
  const int step = detector.config().step_samples(detector.model().sample_time_s);
  const std::size_t n = result.channels.size();
  std::string out = "window,start_s,end_s";
  for (std::size_t k = 0; k < n; ++k) out += ",score_" + std::to_string(k);
  for (std::size_t k = 0; k < n; ++k) out += ",indicator_" + std::to_string(k);
  out += "\n";
  for (std::size_t w = 0; w < result.windows.size(); ++w) {
    const FeatureWindow& fw = result.windows[w];
    const auto r = static_cast<Eigen::Index>(w);
    out +=
        std::to_string(fw.first / step) + "," + csv_number(fw.start_s) + "," + csv_number(fw.end_s);
    for (Eigen::Index k = 0; k < result.scores.cols(); ++k)
      out += "," + csv_number(result.scores(r, k));
    for (Eigen::Index k = 0; k < result.indicator.cols(); ++k)
      out += "," + csv_number(result.indicator(r, k));
    out += "\n";
  }
  return out;
}

void save_detection_json(const std::string& path, const Detector& detector,
                         const DetectionResult& result, int indent) {
  detail::write_file_atomic(path, detection_json(detector, result, indent));
}

void save_detection_alarms_csv(const std::string& path, const Detector& detector,
                               const DetectionResult& result) {
  detail::write_file_atomic(path, detection_alarms_csv(detector, result));
}

void save_detection_scores_csv(const std::string& path, const Detector& detector,
                               const DetectionResult& result) {
  detail::write_file_atomic(path, detection_scores_csv(detector, result));
}

}  // namespace mpmpp
