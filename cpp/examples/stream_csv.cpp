// stream_csv: plant-side monitoring without Python (issue 9).
//
//   stream_csv DETECTOR.json DATA.csv [--alarms-csv FILE] [--scores-csv FILE] [--json FILE]
//                                     [--checkpoint FILE] [--stop-after N]
//
// Loads a detector trained and saved by Python (mpmpp detect --save-detector, or
// mpmpp.Detector.save), reads a data file (FORMATS.md "Data file") and pushes its samples
// one by one into a StreamingDetector, as a historian would. Prints each alarm as it starts
// and each skipped window; at the end it can write the alarms (CSV or JSON) and every
// window's scores and indicator (CSV, exact round-trip numbers).
// --checkpoint FILE: resume from FILE when it exists (skipping the rows already consumed),
// and save the stream state there at the end; --stop-after N stops after N samples in all
// (to show a restart).
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include "mpmpp/data_io.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/streaming_detector.hpp"

namespace {

struct Args {
  std::string detector, data, alarms_csv, scores_csv, json, checkpoint;
  long long stop_after = -1;
};

[[noreturn]] void usage(const std::string& what) {
  std::cerr << "stream_csv: " << what
            << "\nusage: stream_csv DETECTOR.json DATA.csv [--alarms-csv FILE] [--scores-csv FILE] [--json FILE]"
               " [--checkpoint FILE] [--stop-after N]\n";
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
    if (s == "--alarms-csv") a.alarms_csv = value();
    else if (s == "--scores-csv") a.scores_csv = value();
    else if (s == "--json") a.json = value();
    else if (s == "--checkpoint") a.checkpoint = value();
    else if (s == "--stop-after") {
      const std::string v = value();
      char* end = nullptr;
      a.stop_after = std::strtoll(v.c_str(), &end, 10);
      if (*end != '\0' || a.stop_after < 0) usage("--stop-after: expected a sample count, got \"" + v + "\"");
    } else if (s.rfind("--", 0) == 0) usage("unknown option " + s);
    else positional.push_back(s);
  }
  if (positional.size() != 2) usage("expected DETECTOR.json and DATA.csv");
  a.detector = positional[0];
  a.data = positional[1];
  return a;
}

std::string number(double v) {  // 17 significant digits: reads back exactly; empty for NaN
  if (v != v) return "";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) { out += ' '; continue; }
    out += c;
  }
  return out + "\"";
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  if (!f || !(f << text) || !f.flush()) throw mpmpp::InputError(path + ": cannot write");
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse_args(argc, argv);
  try {
    mpmpp::StreamingDetector stream = mpmpp::StreamingDetector::load(args.detector);
    const mpmpp::Model& model = stream.detector().model();
    const auto& channels = stream.detector().channels();
    if (!args.checkpoint.empty() && std::ifstream(args.checkpoint)) stream.load_checkpoint(args.checkpoint);

    const mpmpp::DataTable data = mpmpp::read_csv(args.data);
    auto columns_of = [&](const std::vector<std::string>& names, const char* kind) {
      std::vector<int> cols;
      for (const auto& name : names) {
        const int c = data.column(name);
        if (c < 0) throw mpmpp::InputError(args.data + ": column \"" + name + "\" (model " + kind + ") is missing");
        cols.push_back(c);
      }
      return cols;
    };
    const std::vector<int> u_cols = columns_of(model.inputs, "input"), y_cols = columns_of(model.outputs, "output");

    std::string alarms_csv = "kind,output,input,start_s\n", alarms_json, skipped_json;
    std::string scores_csv = "window,start_s,end_s";
    for (size_t k = 0; k < channels.size(); ++k) scores_csv += ",score_" + std::to_string(k);
    for (size_t k = 0; k < channels.size(); ++k) scores_csv += ",indicator_" + std::to_string(k);
    scores_csv += "\n";

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
      scores_csv += std::to_string(w.window) + "," + number(w.start_s) + "," + number(w.end_s);
      for (Eigen::Index k = 0; k < w.scores.size(); ++k) scores_csv += "," + number(w.scores[k]);
      for (Eigen::Index k = 0; k < w.indicator.size(); ++k) scores_csv += "," + number(w.indicator[k]);
      scores_csv += "\n";
      if (w.skipped) {
        std::printf("window %d (%s .. %s s) skipped: %s\n", w.window, number(w.start_s).c_str(),
                    number(w.end_s).c_str(), w.skip_reason.c_str());
        skipped_json += std::string(skipped_json.empty() ? "" : ", ") + "{\"start_s\": " + number(w.start_s) +
                        ", \"end_s\": " + number(w.end_s) + ", \"reason\": " + json_string(w.skip_reason) + "}";
      }
      for (int k : w.alarm_starts) {
        const mpmpp::MonitoredChannel& c = channels[k];
        const bool process = c.kind == mpmpp::MonitoredChannel::Kind::Process;
        const std::string input = process ? model.inputs[c.input] : "";
        std::printf("alarm %-5s %-28s starts at %s s (%.2f h), indicator %.3f\n", process ? "MPM" : "noise",
                    mpmpp::channel_label(model, c).c_str(), number(w.end_s).c_str(), w.end_s / 3600.0,
                    w.indicator[k]);
        char start[64];
        std::snprintf(start, sizeof start, "%.3f", w.end_s);
        alarms_csv += std::string(process ? "process" : "noise") + "," + model.outputs[c.output] + "," + input + "," +
                      start + "\n";
        alarms_json += std::string(alarms_json.empty() ? "" : ", ") + "{\"kind\": \"" +
                       (process ? "process" : "noise") + "\", \"output\": " + json_string(model.outputs[c.output]) +
                       (process ? ", \"input\": " + json_string(input) : std::string()) +
                       ", \"start_s\": " + number(w.end_s) + "}";
      }
      std::fflush(stdout);
    }
    std::printf("%" PRId64 " samples, %d windows streamed\n", stream.samples(), stream.windows());
    if (!args.checkpoint.empty()) stream.save_checkpoint(args.checkpoint);
    if (!args.alarms_csv.empty()) write_file(args.alarms_csv, alarms_csv);
    if (!args.scores_csv.empty()) write_file(args.scores_csv, scores_csv);
    if (!args.json.empty())
      write_file(args.json, "{\"alarms\": [" + alarms_json + "], \"skipped_windows\": [" + skipped_json +
                                "], \"samples\": " + std::to_string(stream.samples()) +
                                ", \"windows\": " + std::to_string(stream.windows()) + "}\n");
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "stream_csv: " << e.what() << "\n";
    return 1;
  }
}
