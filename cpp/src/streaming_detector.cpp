#include "mpmpp/streaming_detector.hpp"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <nlohmann/json.hpp>

#include "mpmpp/error.hpp"
#include "text_file.hpp"

namespace mpmpp {

using nlohmann::json;

namespace {

// Same relative tolerance on the time step as validate_data (data_io.cpp).
constexpr double kSpacingTolerance = 1e-6;

std::uint64_t fnv1a(const std::string& text) {
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ULL;
  return h;
}

// The shortest fixed form that reads back exactly ("120 s", "105.000001 s"); %.17g else.
std::string seconds(double t) {
  char buf[64];
  for (int decimals = 0; decimals <= 9 && std::abs(t) < 1e15; ++decimals) {
    std::snprintf(buf, sizeof buf, "%.*f", decimals, t);
    if (std::strtod(buf, nullptr) == t) return std::string(buf) + " s";
  }
  std::snprintf(buf, sizeof buf, "%.17g", t);
  return std::string(buf) + " s";
}

// Samples from the first sample of the earliest pooled window to the newest.
int ring_samples(const Detector& d, int window, int step) {
  bool pooled = false;
  for (size_t k = 0; k < d.channels().size(); ++k) pooled = pooled || d.pools(static_cast<int>(k));
  return pooled ? window + (d.config().pooled_windows - 1) * d.pooling_lag() * step : window;
}

}  // namespace

StreamingDetector::StreamingDetector(Detector detector)
    : detector_(std::move(detector)),
      fingerprint_(fnv1a(detector_.to_json())),
      features_(detector_.make_features()),
      window_(features_.window_samples()),
      step_(features_.step_samples()),
      ring_(ring_samples(detector_, window_, step_)),
      sample_time_s_(detector_.model().sample_time_s),
      ring_time_(ring_),
      ring_u_(ring_, detector_.model().num_inputs()),
      ring_y_(ring_, detector_.model().num_outputs()),
      window_u_(window_, detector_.model().num_inputs()),
      window_y_(window_, detector_.model().num_outputs()) {
  for (size_t k = 0; k < detector_.channels().size(); ++k)
    indicators_.emplace_back(detector_.config().inspection_windows(),
                             detector_.config().alarm_count());
}

StreamingDetector StreamingDetector::load(const std::string& detector_path) {
  return StreamingDetector(Detector::load(detector_path));
}

void StreamingDetector::check_sample(double time_s, double previous_time_s, bool first,
                                     const Eigen::Ref<const Eigen::VectorXd>& u,
                                     const Eigen::Ref<const Eigen::VectorXd>& y,
                                     const std::string& where) const {
  const Model& m = detector_.model();
  if (u.size() != m.num_inputs())
    throw InputError(where + "u: " + std::to_string(u.size()) + " values, the model has " +
                     std::to_string(m.num_inputs()) + " inputs");
  if (y.size() != m.num_outputs())
    throw InputError(where + "y: " + std::to_string(y.size()) + " values, the model has " +
                     std::to_string(m.num_outputs()) + " outputs");
  for (Eigen::Index j = 0; j < u.size(); ++j)
    if (std::isinf(u[j]))
      throw InputError(where + "u: input " + m.inputs[j] + " is infinite (use NaN for missing)");
  for (Eigen::Index i = 0; i < y.size(); ++i)
    if (std::isinf(y[i]))
      throw InputError(where + "y: output " + m.outputs[i] + " is infinite (use NaN for missing)");
  if (!std::isfinite(time_s))
    throw InputError(where + "time_s: must be a finite number of seconds");
  if (first) return;
  const double step = time_s - previous_time_s;
  if (std::abs(step - sample_time_s_) > kSpacingTolerance * sample_time_s_)
    throw InputError(where + "time_s: sample at " + seconds(time_s) + " comes " + seconds(step) +
                     " after the previous one (" + seconds(previous_time_s) +
                     "), expected the model's sample_time_s = " + seconds(sample_time_s_) +
                     (step > sample_time_s_ ? "; push missing samples as NaN rows" : ""));
}

bool StreamingDetector::push(double time_s, const Eigen::Ref<const Eigen::VectorXd>& u,
                             const Eigen::Ref<const Eigen::VectorXd>& y, StreamWindow& window) {
  check_sample(time_s, last_time_, samples_ == 0, u, y, "");
  return take(time_s, u, y, window);
}

std::vector<StreamWindow> StreamingDetector::push_block(
    const Eigen::Ref<const Eigen::VectorXd>& time_s, const Eigen::Ref<const Eigen::MatrixXd>& u,
    const Eigen::Ref<const Eigen::MatrixXd>& y) {
  const Eigen::Index n = time_s.size();
  if (u.rows() != n || y.rows() != n)
    throw InputError("push_block: time_s, u and y must have the same number of rows (" +
                     std::to_string(n) + ", " + std::to_string(u.rows()) + ", " +
                     std::to_string(y.rows()) + ")");
  for (Eigen::Index r = 0; r < n; ++r)
    check_sample(time_s[r], r == 0 ? last_time_ : time_s[r - 1], r == 0 && samples_ == 0,
                 u.row(r).transpose(), y.row(r).transpose(),
                 "push_block: row " + std::to_string(r) + ": ");
  std::vector<StreamWindow> out;
  StreamWindow w;
  for (Eigen::Index r = 0; r < n; ++r)
    if (take(time_s[r], u.row(r).transpose(), y.row(r).transpose(), w)) out.push_back(std::move(w));
  return out;
}

bool StreamingDetector::take(double time_s, const Eigen::Ref<const Eigen::VectorXd>& u,
                             const Eigen::Ref<const Eigen::VectorXd>& y, StreamWindow& window) {
  if (samples_ == 0) {
    t0_ = time_s;
    // As Detector::monitor: training windows end by the first sample + train_end_s, with
    // half a sample of slack for times read back from a CSV.
    train_end_abs_ = t0_ + detector_.train_end_s() + 0.5 * sample_time_s_;
  }
  ring_time_[next_] = time_s;
  ring_u_.row(next_) = u.transpose();
  ring_y_.row(next_) = y.transpose();
  next_ = (next_ + 1) % ring_;
  last_time_ = time_s;
  ++samples_;
  // Batch windows start at samples 0, step, 2 step, ...: window w ends at sample w step + W.
  if (samples_ < window_ || (samples_ - window_) % step_ != 0) return false;
  complete_window(window);
  return true;
}

void StreamingDetector::unroll(int back, Eigen::MatrixXd& u, Eigen::MatrixXd& y) const {
  const int first = ((next_ - back - window_) % ring_ + ring_) % ring_;
  for (int r = 0; r < window_; ++r) {
    const int k = (first + r) % ring_;
    u.row(r) = ring_u_.row(k);
    y.row(r) = ring_y_.row(k);
  }
}

void StreamingDetector::complete_window(StreamWindow& w) {
  // The contiguous window ARX-OE expects, oldest row first.
  unroll(0, window_u_, window_y_);

  const int n_channels = static_cast<int>(indicators_.size());
  w.window = windows_++;
  w.start_s = ring_time_[((next_ - window_) % ring_ + ring_) % ring_];  // its oldest sample
  w.end_s = last_time_ + sample_time_s_;
  w.training = w.end_s <= train_end_abs_;
  w.skip_reason.clear();
  // The disjoint windows pooled with this one, as monitor takes them from its series (training
  // windows score 0 whatever they pool).
  std::vector<WindowEstimates> earlier;
  if (ring_ > window_ && !w.training) {
    Eigen::MatrixXd u(window_, ring_u_.cols()), y(window_, ring_y_.cols());
    for (int m = 1; m < detector_.config().pooled_windows; ++m) {
      const int back = m * detector_.pooling_lag() * step_;
      if (samples_ < static_cast<std::int64_t>(window_) + back) break;
      unroll(back, u, y);
      WindowEstimates e;
      if (!features_.extract(u, y, e.features, nullptr, &e.covariances)) e = WindowEstimates{};
      earlier.push_back(std::move(e));
    }
  }
  w.scores = detector_.score_window(features_, window_u_, window_y_, &w.skip_reason, earlier);
  w.skipped = !w.scores.allFinite();
  if (!w.skipped) w.skip_reason.clear();
  if (w.training) w.scores.setZero();  // as in the paper (and monitor): 0 while training
  w.indicator.resize(n_channels);
  w.alarm.assign(n_channels, false);
  w.alarm_starts.clear();
  for (int k = 0; k < n_channels; ++k) {
    if (!detector_.counts_for_indicator(w.scores, k)) {
      w.indicator[k] = indicators_[k].indicator();
      w.alarm[k] = indicators_[k].alarm();
      continue;
    }
    const auto update = indicators_[k].push(w.scores[k]);
    w.indicator[k] = update.indicator;
    w.alarm[k] = update.alarm;
    if (update.started) w.alarm_starts.push_back(k);
  }
}

std::vector<bool> StreamingDetector::alarm() const {
  std::vector<bool> a;
  for (const auto& ind : indicators_) a.push_back(ind.alarm());
  return a;
}

// ------------------------------------------------------------------------------ checkpoint

namespace {

json number_or_null(double v) { return std::isnan(v) ? json(nullptr) : json(v); }

}  // namespace

std::string StreamingDetector::checkpoint_json() const {
  // Ring rows oldest first: the min(samples, ring) samples actually pushed.
  const int filled = samples_ < ring_ ? static_cast<int>(samples_) : ring_;
  const int oldest = samples_ < ring_ ? 0 : next_;
  json time = json::array(), u = json::array(), y = json::array();
  for (int r = 0; r < filled; ++r) {
    const int k = (oldest + r) % ring_;
    time.push_back(ring_time_[k]);
    json ur = json::array(), yr = json::array();
    for (Eigen::Index j = 0; j < ring_u_.cols(); ++j) ur.push_back(number_or_null(ring_u_(k, j)));
    for (Eigen::Index i = 0; i < ring_y_.cols(); ++i) yr.push_back(number_or_null(ring_y_(k, i)));
    u.push_back(std::move(ur));
    y.push_back(std::move(yr));
  }
  json indicators = json::array();
  for (const auto& ind : indicators_)
    indicators.push_back({{"history", ind.history()}, {"alarm", ind.alarm()}});
  json j{{"format", "mpmpp-stream-checkpoint"},
         {"version", kCheckpointVersion},
         {"detector_fingerprint", fingerprint_},
         {"samples", samples_},
         {"windows", windows_},
         {"t0", t0_},
         {"last_time", last_time_},
         {"time", time},
         {"u", u},
         {"y", y},
         {"indicators", indicators}};
  return j.dump();
}

void StreamingDetector::save_checkpoint(const std::string& path) const {
  detail::write_file_atomic(path, checkpoint_json());
}

void StreamingDetector::restore_checkpoint_json(const std::string& text,
                                                const std::string& source) {
  auto fail = [&](const std::string& what) -> void { throw InputError(source + ": " + what); };
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(
        source + ": not a complete JSON document (truncated or corrupt checkpoint?): " + e.what());
  }
  // Every field is read before any state changes: a bad checkpoint leaves the stream as it was.
  try {
    if (!j.is_object() || j.value("format", "") != "mpmpp-stream-checkpoint")
      fail("format: not an mpmpp stream checkpoint (expected \"mpmpp-stream-checkpoint\")");
    const int version = j.at("version").get<int>();
    if (version < 1 || version > kCheckpointVersion)
      fail("version: checkpoint format version " + std::to_string(version) +
           " is not supported (this mpmpp reads " + std::to_string(kCheckpointVersion) + ")");
    if (j.at("detector_fingerprint").get<std::uint64_t>() != fingerprint_)
      fail("detector_fingerprint: the checkpoint belongs to another detector file");
    const std::int64_t samples = j.at("samples").get<std::int64_t>();
    const int windows = j.at("windows").get<int>();
    const double t0 = j.at("t0").get<double>(), last_time = j.at("last_time").get<double>();
    if (samples < 0) fail("samples: must be >= 0");
    const std::int64_t expected_windows = samples < window_ ? 0 : (samples - window_) / step_ + 1;
    if (windows != expected_windows)
      fail("windows: " + std::to_string(windows) + " does not match " + std::to_string(samples) +
           " samples");
    const int filled = samples < ring_ ? static_cast<int>(samples) : ring_;
    const json &time = j.at("time"), &u = j.at("u"), &y = j.at("y"), &ind = j.at("indicators");
    if (!time.is_array() || !u.is_array() || !y.is_array() ||
        time.size() != static_cast<size_t>(filled) || u.size() != time.size() ||
        y.size() != time.size())
      fail("time/u/y: expected " + std::to_string(filled) + " buffered samples each");
    Eigen::VectorXd ring_time = Eigen::VectorXd::Zero(ring_);
    Eigen::MatrixXd ring_u = Eigen::MatrixXd::Zero(ring_, ring_u_.cols());
    Eigen::MatrixXd ring_y = Eigen::MatrixXd::Zero(ring_, ring_y_.cols());
    auto read_row = [&](const json& row, Eigen::MatrixXd& into, int r, const char* name) {
      if (!row.is_array() || row.size() != static_cast<size_t>(into.cols()))
        fail(std::string(name) + "[" + std::to_string(r) + "]: expected " +
             std::to_string(into.cols()) + " values");
      for (size_t c = 0; c < row.size(); ++c)
        into(r, c) =
            row[c].is_null() ? std::numeric_limits<double>::quiet_NaN() : row[c].get<double>();
    };
    for (int r = 0; r < filled; ++r) {
      ring_time[r] = time[r].get<double>();
      read_row(u[r], ring_u, r, "u");
      read_row(y[r], ring_y, r, "y");
    }
    // The sample count fixes where the next window ends: it must agree with the times.
    if (filled > 0 &&
        (ring_time[filled - 1] != last_time ||
         std::abs(last_time - t0 - static_cast<double>(samples - 1) * sample_time_s_) >
             kSpacingTolerance * sample_time_s_ * static_cast<double>(samples)))
      fail("samples: " + std::to_string(samples) +
           " samples do not span t0 .. last_time at the sample time");
    if (!ind.is_array() || ind.size() != indicators_.size())
      fail("indicators: expected " + std::to_string(indicators_.size()) + " channels");
    std::vector<MismatchIndicator> indicators = indicators_;
    for (size_t k = 0; k < indicators.size(); ++k)
      indicators[k].restore(ind[k].at("history").get<std::vector<std::uint8_t>>(),
                            ind[k].at("alarm").get<bool>());
    // Commit: the ring is stored oldest-first from row 0, so the next write goes to row
    // filled % ring.
    ring_time_ = ring_time;
    ring_u_ = ring_u;
    ring_y_ = ring_y;
    next_ = filled % ring_;
    samples_ = samples;
    windows_ = windows;
    t0_ = t0;
    last_time_ = last_time;
    train_end_abs_ = t0_ + detector_.train_end_s() + 0.5 * sample_time_s_;
    indicators_ = std::move(indicators);
  } catch (const json::exception& e) {
    throw InputError(source + ": malformed checkpoint: " + e.what());
  } catch (const InputError& e) {
    const std::string what = e.what();
    if (what.rfind(source, 0) == 0) throw;
    throw InputError(source + ": " + what);
  }
}

void StreamingDetector::load_checkpoint(const std::string& path) {
  restore_checkpoint_json(detail::read_text_file(path), path);
}

}  // namespace mpmpp
