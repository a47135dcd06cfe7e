// stream_csv: plant-side monitoring without Python.
//
//   stream_csv DETECTOR.json DATA.csv [OUTPUTS] [--checkpoint FILE] [--stop-after N]
//   stream_csv --train MODEL.json --train-end SECONDS [--config FILE|PRESET]
//              [--save-detector FILE] DATA.csv [OUTPUTS] [--stop-after N]
//   OUTPUTS: [--alarms-csv FILE] [--scores-csv FILE] [--json FILE]
//
// Loads a trained detector (saved by `mpmpp detect --save-detector`, mpmpp.Detector.save or
// this program), or trains one here (train_detector) on the windows of DATA ending within
// SECONDS of its first sample, as `mpmpp detect` does; to retrain on newer normal data, run
// again with --train on that data. Then reads a data file (docs/formats.md "Data file") and pushes
// its samples one by one into a StreamingDetector, as a historian would. Prints each alarm as
// it starts and each skipped window; at the end it writes the detection results (detector_io:
// alarms CSV, scores CSV, the `detect --json` document), atomically.
// --checkpoint FILE: resume from FILE when it exists (skipping the rows already consumed),
// and save the stream state there at the end; --stop-after N stops after N samples in all
// (to show a restart). The files then hold the windows of this run only.
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "mpmpp/data_io.hpp"
#include "mpmpp/detector_io.hpp"
#include "mpmpp/detector_training.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/model_io.hpp"
#include "mpmpp/streaming_detector.hpp"

namespace {

struct Args {
  std::string detector, data, alarms_csv, scores_csv, json, checkpoint;
  std::string train_model, config, save_detector;
  std::optional<double> train_end_s;
  long long stop_after = -1;
};

[[noreturn]] void usage(const std::string& what) {
  std::cerr << "stream_csv: " << what
            << "\nusage: stream_csv DETECTOR.json DATA.csv [--alarms-csv FILE] [--scores-csv FILE] "
               "[--json FILE]"
               " [--checkpoint FILE] [--stop-after N]\n"
               "       stream_csv --train MODEL.json --train-end SECONDS [--config FILE|PRESET] "
               "[--save-detector FILE]"
               " DATA.csv [--alarms-csv FILE] [--scores-csv FILE] [--json FILE] [--stop-after N]\n";
  std::exit(2);
}

Args parse_args(int argc, char** argv) {
  Args a;
  std::vector<std::string> positional;
  for (int k = 1; k < argc; ++k) {
    const std::string s = argv[k];
    auto value = [&]() -> std::string {
      if (k + 1 >= argc) usage(s + " needs a value");
      return argv[++k];
    };
    if (s == "--alarms-csv")
      a.alarms_csv = value();
    else if (s == "--scores-csv")
      a.scores_csv = value();
    else if (s == "--json")
      a.json = value();
    else if (s == "--checkpoint")
      a.checkpoint = value();
    else if (s == "--train")
      a.train_model = value();
    else if (s == "--config")
      a.config = value();
    else if (s == "--save-detector")
      a.save_detector = value();
    else if (s == "--train-end") {
      const std::string v = value();
      char* end = nullptr;
      a.train_end_s = std::strtod(v.c_str(), &end);
      if (*end != '\0' || !(*a.train_end_s > 0))
        usage("--train-end: expected seconds > 0, got \"" + v + "\"");
    } else if (s == "--stop-after") {
      const std::string v = value();
      char* end = nullptr;
      a.stop_after = std::strtoll(v.c_str(), &end, 10);
      if (*end != '\0' || a.stop_after < 0)
        usage("--stop-after: expected a sample count, got \"" + v + "\"");
    } else if (s.rfind("--", 0) == 0)
      usage("unknown option " + s);
    else
      positional.push_back(s);
  }
  if (a.train_model.empty()) {
    if (a.train_end_s || !a.config.empty() || !a.save_detector.empty())
      usage("--train-end, --config and --save-detector need --train MODEL.json");
    if (positional.size() != 2) usage("expected DETECTOR.json and DATA.csv");
    a.detector = positional[0];
    a.data = positional[1];
  } else {
    if (!a.train_end_s) usage("--train needs --train-end SECONDS");
    if (!a.checkpoint.empty())
      usage("--checkpoint resumes a saved detector's stream, not a training run");
    if (positional.size() != 1) usage("with --train, expected DATA.csv only");
    a.data = positional[0];
  }
  return a;
}

mpmpp::DetectorConfig read_config(const std::string& spec) {
  if (spec.empty()) return mpmpp::DetectorConfig::siso();
  if (spec == "siso" || spec == "mimo" || spec == "paper_siso" || spec == "paper_mimo")
    return mpmpp::DetectorConfig::preset(spec);
  std::ifstream f(spec, std::ios::binary);
  if (!f) throw mpmpp::InputError(spec + ": cannot read the detector config");
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  try {
    return mpmpp::DetectorConfig::from_json(text);
  } catch (const mpmpp::InputError& e) {
    throw mpmpp::InputError(spec + ": " + e.what());
  }
}

// The model's columns of `data` (InputError naming a missing one).
std::vector<int> columns_of(const mpmpp::DataTable& data, const std::string& source,
                            const std::vector<std::string>& names, const char* kind) {
  std::vector<int> cols;
  for (const auto& name : names) {
    const int c = data.column(name);
    if (c < 0)
      throw mpmpp::InputError(source + ": column \"" + name + "\" (model " + kind + ") is missing");
    cols.push_back(c);
  }
  return cols;
}

Eigen::MatrixXd gather(const mpmpp::DataTable& data, const std::vector<int>& cols) {
  Eigen::MatrixXd m(data.num_samples(), static_cast<Eigen::Index>(cols.size()));
  for (std::size_t j = 0; j < cols.size(); ++j)
    m.col(static_cast<Eigen::Index>(j)) = data.values.col(cols[j]);
  return m;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse_args(argc, argv);
  try {
    const mpmpp::DataTable data = mpmpp::read_csv(args.data);
    std::optional<mpmpp::StreamingDetector> loaded;
    if (args.train_model.empty()) {
      loaded.emplace(mpmpp::StreamingDetector::load(args.detector));
    } else {
      const mpmpp::Model model = mpmpp::load_model(args.train_model);
      mpmpp::DetectorConfig config = read_config(args.config);
      if (args.config.empty() && model.num_outputs() > 1) config = mpmpp::DetectorConfig::mimo();
      const Eigen::MatrixXd u = gather(data, columns_of(data, args.data, model.inputs, "input"));
      const Eigen::MatrixXd y = gather(data, columns_of(data, args.data, model.outputs, "output"));
      mpmpp::Detector trained =
          mpmpp::train_detector(model, config, data.time_s, u, y, *args.train_end_s);
      if (!args.save_detector.empty()) trained.save(args.save_detector);
      std::printf("trained on %g s of %s\n", *args.train_end_s, args.data.c_str());
      loaded.emplace(std::move(trained));
    }
    mpmpp::StreamingDetector& stream = *loaded;
    const mpmpp::Detector& detector = stream.detector();
    const mpmpp::Model& model = detector.model();
    if (!args.checkpoint.empty() && std::ifstream(args.checkpoint))
      stream.load_checkpoint(args.checkpoint);
    const std::vector<int> u_cols = columns_of(data, args.data, model.inputs, "input");
    const std::vector<int> y_cols = columns_of(data, args.data, model.outputs, "output");

    // This run's windows, in the batch result's form, for the detector_io writers.
    mpmpp::DetectionResult result;
    result.channels = detector.channels();
    std::vector<Eigen::VectorXd> scores, indicator;
    Eigen::VectorXd u(u_cols.size()), y(y_cols.size());
    mpmpp::StreamWindow w;
    const long long n = data.num_samples();
    const long long last = args.stop_after >= 0 ? std::min<long long>(n, args.stop_after) : n;
    for (long long r = stream.samples(); r < last; ++r) {
      for (size_t j = 0; j < u_cols.size(); ++j) u[j] = data.values(r, u_cols[j]);
      for (size_t i = 0; i < y_cols.size(); ++i) y[i] = data.values(r, y_cols[i]);
      bool completed = false;
      try {
        completed = stream.push(data.time_s[r], u, y, w);
      } catch (const mpmpp::InputError& e) {
        throw mpmpp::InputError(args.data + ": row " + std::to_string(r + 2) + ": " + e.what());
      }
      if (!completed) continue;
      result.windows.push_back(
          {w.window * stream.step_samples(), w.start_s, w.end_s, w.skipped, w.skip_reason});
      result.training.push_back(w.training);
      scores.push_back(w.scores);
      indicator.push_back(w.indicator);
      if (w.skipped)
        std::printf("window %d (%.17g .. %.17g s) skipped: %s\n", w.window, w.start_s, w.end_s,
                    w.skip_reason.c_str());
      for (int k : w.alarm_starts) {
        result.alarms.push_back({k, static_cast<int>(result.windows.size()) - 1, w.end_s});
        std::printf(
            "alarm %-5s %-28s starts at %.17g s (%.2f h), indicator %.3f\n",
            result.channels[k].kind == mpmpp::MonitoredChannel::Kind::Process ? "MPM" : "noise",
            mpmpp::channel_label(model, result.channels[k]).c_str(), w.end_s, w.end_s / 3600.0,
            w.indicator[k]);
      }
      std::fflush(stdout);
    }
    const auto n_windows = static_cast<Eigen::Index>(scores.size());
    const auto n_channels = static_cast<Eigen::Index>(result.channels.size());
    result.scores.resize(n_windows, n_channels);
    result.indicator.resize(n_windows, n_channels);
    for (Eigen::Index k = 0; k < n_windows; ++k) {
      result.scores.row(k) = scores[k].transpose();
      result.indicator.row(k) = indicator[k].transpose();
    }
    std::printf("%" PRId64 " samples, %d windows streamed\n", stream.samples(), stream.windows());
    if (!args.checkpoint.empty()) stream.save_checkpoint(args.checkpoint);
    if (!args.alarms_csv.empty())
      mpmpp::save_detection_alarms_csv(args.alarms_csv, detector, result);
    if (!args.scores_csv.empty())
      mpmpp::save_detection_scores_csv(args.scores_csv, detector, result);
    if (!args.json.empty()) mpmpp::save_detection_json(args.json, detector, result);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "stream_csv: " << e.what() << "\n";
    return dynamic_cast<const mpmpp::InputError*>(&e) ? 2 : 1;  // 2: bad input, as the mpmpp CLI
  }
}
