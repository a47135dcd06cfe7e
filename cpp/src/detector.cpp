#include "mpmpp/detector.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <tuple>
#include <utility>

#include "detector_config_json.hpp"
#include "mpmpp/chi_square.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/mismatch_indicator.hpp"
#include "mpmpp/model_io.hpp"
#include "mpmpp/one_class_svm.hpp"
#include "mpmpp/window_pooling.hpp"
#include "text_file.hpp"

namespace mpmpp {

using nlohmann::json;

// ---------------------------------------------------------------------------- ChannelScorer

namespace {

// Symmetric square root of a symmetric positive definite matrix, or of its inverse; false
// when it is not positive definite.
bool symmetric_root(const Eigen::MatrixXd& m, bool inverse, Eigen::MatrixXd& root) {
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(m);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues().minCoeff() > 0)) return false;
  Eigen::VectorXd r = eig.eigenvalues().cwiseSqrt();
  if (inverse) r = r.cwiseInverse();
  root = eig.eigenvectors() * r.asDiagonal() * eig.eigenvectors().transpose();
  return true;
}

// Channel k's estimate (x, c) pooled with the finite ones of `earlier` (window_pooling.hpp).
PooledEstimate pooled_with(const Eigen::VectorXd& x, const Eigen::MatrixXd& c,
                           const std::vector<WindowEstimates>& earlier, size_t k) {
  std::vector<Eigen::VectorXd> xs{x};
  std::vector<Eigen::MatrixXd> cs{c};
  for (const WindowEstimates& e : earlier) {
    if (e.features.size() <= k || !e.features[k].allFinite() || !e.covariances[k].allFinite())
      continue;
    xs.push_back(e.features[k]);
    cs.push_back(e.covariances[k]);
  }
  return pool_estimates(xs, cs);
}

}  // namespace

double ChannelScorer::score(const Eigen::Ref<const Eigen::VectorXd>& x) const {
  if (reference_covariance.size() != 0)
    throw InputError(
        "detector: this channel scores a window together with its covariance (resampling "
        "'estimator')");
  return score(x, Eigen::MatrixXd());
}

double ChannelScorer::wald_log_p_value(
    const Eigen::Ref<const Eigen::VectorXd>& x,
    const Eigen::Ref<const Eigen::MatrixXd>& window_covariance) const {
  return mpmpp::wald_log_p_value(x - feature_mean, window_covariance + mean_covariance);
}

double wald_log_p_value(const Eigen::Ref<const Eigen::VectorXd>& deviation,
                        const Eigen::Ref<const Eigen::MatrixXd>& S) {
  // In correlation form, so that the rank cut does not depend on the directions' units (a
  // direction without variance drops out).
  const Eigen::Index n = deviation.size();
  Eigen::VectorXd inv_sd(n);
  for (Eigen::Index k = 0; k < n; ++k) inv_sd[k] = S(k, k) > 0 ? 1.0 / std::sqrt(S(k, k)) : 0.0;
  const Eigen::VectorXd z = inv_sd.cwiseProduct(deviation);
  const Eigen::MatrixXd R = inv_sd.asDiagonal() * S * inv_sd.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(R);
  if (eig.info() != Eigen::Success) return std::numeric_limits<double>::quiet_NaN();
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const double cut = ChannelScorer::kWaldRankTolerance * lambda.maxCoeff();
  double T = 0;
  int dof = 0;
  for (Eigen::Index k = 0; k < n; ++k) {
    if (!(lambda[k] > cut)) continue;
    const double proj = eig.eigenvectors().col(k).dot(z);
    T += proj * proj / lambda[k];
    ++dof;
  }
  return dof == 0 ? std::numeric_limits<double>::quiet_NaN() : chi_square_log_survival(T, dof);
}

double ChannelScorer::score(const Eigen::Ref<const Eigen::VectorXd>& x,
                            const Eigen::Ref<const Eigen::MatrixXd>& window_covariance) const {
  if ((significance > 0 || reference_covariance.size() != 0) &&
      (window_covariance.rows() != x.size() || window_covariance.cols() != x.size()))
    throw InputError("detector: the window covariance must be " + std::to_string(x.size()) + " x " +
                     std::to_string(x.size()));
  if (significance > 0) {
    const double log_p = wald_log_p_value(x, window_covariance);  // against the training mean
    if (!(confirmation > 0)) return (log_p - std::log(significance)) / std::log(10.0);
    const double log_p0 = mpmpp::wald_log_p_value(x, window_covariance);  // against the model
    if (std::isnan(log_p) || std::isnan(log_p0)) return std::numeric_limits<double>::quiet_NaN();
    return std::max(log_p0 - std::log(significance), log_p - std::log(confirmation)) /
           std::log(10.0);
  }
  Eigen::VectorXd deviation = x - feature_mean;
  if (reference_covariance.size() != 0) {
    Eigen::MatrixXd reference_root, window_inverse_root;
    const Eigen::MatrixXd deviation_covariance =
        mean_covariance.size() != 0 ? Eigen::MatrixXd(window_covariance + mean_covariance)
                                    : Eigen::MatrixXd(window_covariance);
    if (!symmetric_root(reference_covariance, false, reference_root) ||
        !symmetric_root(deviation_covariance, true, window_inverse_root))
      return std::numeric_limits<double>::quiet_NaN();
    deviation = reference_root * (window_inverse_root * deviation);
  }
  RowMatrixXd z = (deviation.array() / feature_scale.array()).matrix().transpose();
  if (feature_decorrelation.size() != 0) z = z * feature_decorrelation.transpose();
  const double f =
      gaussian_kernel_expansion(support_vectors, dual_coef, kernel_scale, z)[0] - offset;
  return f / (nu * n_train);  // eq. 20: h = f / (nu l)
}

Eigen::VectorXd ChannelScorer::score_rows(
    const Eigen::Ref<const Eigen::MatrixXd>& X,
    const Eigen::Ref<const Eigen::MatrixXd>& covariances) const {
  const Eigen::Index d = X.cols();
  const bool with_covariance = reference_covariance.size() != 0;
  if (with_covariance && (covariances.rows() != X.rows() || covariances.cols() != d * d))
    throw InputError("detector: window covariances must be " + std::to_string(X.rows()) + " x " +
                     std::to_string(d * d) + " (one row-major d x d matrix per window)");
  // Row by row through score(): a blocked kernel product would sum in a different order than
  // the one-window (streaming) path, and batch and streaming scores must be bit-identical.
  Eigen::VectorXd h = Eigen::VectorXd::Constant(X.rows(), std::numeric_limits<double>::quiet_NaN());
  for (Eigen::Index r = 0; r < X.rows(); ++r) {
    if (!X.row(r).allFinite()) continue;
    if (!with_covariance) {
      h[r] = score(X.row(r).transpose(), Eigen::MatrixXd());
      continue;
    }
    if (!covariances.row(r).allFinite()) continue;
    const Eigen::MatrixXd c = Eigen::Map<const RowMatrixXd>(covariances.row(r).eval().data(), d, d);
    h[r] = score(X.row(r).transpose(), c);
  }
  return h;
}

void ChannelScorer::validate(int feature_length, const std::string& where) const {
  auto fail = [&](const std::string& what) { throw InputError(where + ": " + what); };
  if (feature_mean.size() != feature_length || feature_scale.size() != feature_length)
    fail("feature_mean/feature_scale must have " + std::to_string(feature_length) + " entries");
  if (!feature_mean.allFinite() || !feature_scale.allFinite() || (feature_scale.array() <= 0).any())
    fail("feature_scale must be finite and positive, feature_mean finite");
  if (feature_decorrelation.size() != 0 &&
      (feature_decorrelation.rows() != feature_length ||
       feature_decorrelation.cols() != feature_length || !feature_decorrelation.allFinite()))
    fail("feature_decorrelation must be empty or a finite " + std::to_string(feature_length) +
         " x " + std::to_string(feature_length) + " matrix");
  if (reference_covariance.size() != 0 &&
      (reference_covariance.rows() != feature_length ||
       reference_covariance.cols() != feature_length || !reference_covariance.allFinite() ||
       !reference_covariance.isApprox(reference_covariance.transpose())))
    fail("reference_covariance must be empty or a finite symmetric " +
         std::to_string(feature_length) + " x " + std::to_string(feature_length) + " matrix");
  if (mean_covariance.size() != 0 &&
      (reference_covariance.size() == 0 || mean_covariance.rows() != feature_length ||
       mean_covariance.cols() != feature_length || !mean_covariance.allFinite() ||
       !mean_covariance.isApprox(mean_covariance.transpose())))
    fail("mean_covariance must be empty or, with reference_covariance, a finite symmetric " +
         std::to_string(feature_length) + " x " + std::to_string(feature_length) + " matrix");
  if (!(confirmation >= 0 && confirmation <= 1))
    fail("confirmation must be in [0, 1] (0 = the training mean alone)");
  if (confirmation > 0 && !(significance > 0)) fail("confirmation needs a Wald-test channel");
  if (significance > 0) {
    if (!(significance < 1)) fail("significance must be in (0, 1)");
    if (reference_covariance.size() == 0 || mean_covariance.size() == 0)
      fail("a Wald-test channel needs reference_covariance and mean_covariance");
    return;
  }
  if (support_vectors.rows() < 1 || support_vectors.cols() != feature_length)
    fail("support_vectors must be n_sv x " + std::to_string(feature_length));
  if (dual_coef.size() != support_vectors.rows())
    fail("dual_coef must have one entry per support vector");
  if (!support_vectors.allFinite() || !dual_coef.allFinite() || !std::isfinite(offset))
    fail("support_vectors, dual_coef and offset must be finite");
  if (!(kernel_scale > 0) || !std::isfinite(kernel_scale)) fail("kernel_scale must be positive");
  if (!(nu > 0 && nu <= 1)) fail("nu must be in (0, 1]");
  if (n_train < 1) fail("n_train must be >= 1");
}

// -------------------------------------------------------------------------------- Detector

std::string channel_label(const std::string& output, const std::string& input) {
  return input.empty() ? "H[" + output + "]" : "G[" + output + " <- " + input + "]";
}

std::string channel_label(const Model& model, const MonitoredChannel& c) {
  return channel_label(model.outputs[c.output],
                       c.kind == MonitoredChannel::Kind::Noise ? "" : model.inputs[c.input]);
}

Detector::Detector(Model nominal, DetectorConfig config, double train_end_s,
                   std::vector<ChannelScorer> scorers)
    : model_(std::move(nominal)),
      config_(std::move(config)),
      train_end_s_(train_end_s),
      scorers_(std::move(scorers)) {
  config_.validate();
  if (!std::isfinite(train_end_s_) || train_end_s_ <= 0)
    throw InputError("detector: train_end_s must be a positive number of seconds");
  const WindowFeatures features(model_, config_);  // checks the model against the config
  channels_ = features.channels();
  if (scorers_.size() != channels_.size())
    throw InputError("detector: " + std::to_string(scorers_.size()) +
                     " channel scorers given, the model has " + std::to_string(channels_.size()) +
                     " monitored channels");
  for (size_t k = 0; k < channels_.size(); ++k)
    scorers_[k].validate(features.feature_length(static_cast<int>(k)),
                         "detector: channel " + channel_label(model_, channels_[k]));
}

DetectionResult Detector::monitor(const Eigen::Ref<const Eigen::VectorXd>& time_s,
                                  const Eigen::Ref<const Eigen::MatrixXd>& u,
                                  const Eigen::Ref<const Eigen::MatrixXd>& y) const {
  WindowFeatures features = make_features();
  return monitor(features.extract_series(time_s, u, y));
}

DetectionResult Detector::monitor(const WindowFeatures::Series& series) const {
  const int n_windows = static_cast<int>(series.windows.size());
  const int n_channels = static_cast<int>(channels_.size());
  if (static_cast<int>(series.features.size()) != n_channels)
    throw InputError("detector: features for " + std::to_string(series.features.size()) +
                     " channels given, expected " + std::to_string(n_channels));
  DetectionResult r;
  r.channels = channels_;
  r.windows = series.windows;
  r.training.assign(n_windows, false);
  r.scores.setZero(n_windows, n_channels);
  r.indicator.setZero(n_windows, n_channels);
  if (n_windows == 0) return r;
  // Training windows end at or before the first window's start + train_end_s (half a sample
  // of slack so that times read back from a CSV compare as intended).
  const double train_end_abs =
      series.windows[0].start_s + train_end_s_ + 0.5 * model_.sample_time_s;
  for (int w = 0; w < n_windows; ++w) r.training[w] = series.windows[w].end_s <= train_end_abs;
  for (int k = 0; k < n_channels; ++k) {
    if (series.features[k].rows() != n_windows)
      throw InputError("detector: features of channel " + std::to_string(k) + " have " +
                       std::to_string(series.features[k].rows()) + " rows, expected " +
                       std::to_string(n_windows));
    const bool with_covariance = scorers_[k].reference_covariance.size() != 0;
    if (with_covariance && series.covariances.size() != static_cast<size_t>(n_channels))
      throw InputError("detector: channel " + channel_label(model_, channels_[k]) +
                       " needs the window covariances (resampling 'estimator')");
    if (pools(k)) {
      // Each window pooled with the disjoint windows before it, as score_window does it.
      const int lag = pooling_lag(), d = static_cast<int>(series.features[k].cols());
      Eigen::MatrixXd X = series.features[k], C = series.covariances[k];
      auto estimate = [&](int w) {
        return std::pair<Eigen::VectorXd, Eigen::MatrixXd>(
            series.features[k].row(w).transpose(),
            Eigen::Map<const RowMatrixXd>(series.covariances[k].row(w).eval().data(), d, d));
      };
      for (int w = 0; w < n_windows; ++w) {
        if (!series.features[k].row(w).allFinite() || !series.covariances[k].row(w).allFinite())
          continue;
        std::vector<WindowEstimates> earlier;
        for (int m = 1; m < config_.pooled_windows && w - m * lag >= 0; ++m) {
          WindowEstimates e;
          e.features.resize(k + 1);
          e.covariances.resize(k + 1);
          std::tie(e.features[k], e.covariances[k]) = estimate(w - m * lag);
          earlier.push_back(std::move(e));
        }
        const auto [x, c] = estimate(w);
        const PooledEstimate p = pooled_with(x, c, earlier, static_cast<size_t>(k));
        X.row(w) = p.mean.transpose();
        C.row(w) = Eigen::Map<const Eigen::RowVectorXd>(RowMatrixXd(p.covariance).data(), d * d);
      }
      r.scores.col(k) = scorers_[k].score_rows(X, C);
    } else {
      r.scores.col(k) = with_covariance
                            ? scorers_[k].score_rows(series.features[k], series.covariances[k])
                            : scorers_[k].score_rows(series.features[k]);
    }
    for (int w = 0; w < n_windows; ++w)
      if (r.training[w]) r.scores(w, k) = 0.0;  // as in the paper: 0 while the SVM is trained
  }
  for (int k = 0; k < n_channels; ++k) {
    MismatchIndicator indicator(config_.inspection_windows(), config_.alarm_count());
    for (int w = 0; w < n_windows; ++w) {
      if (!counts_for_indicator(r.scores.row(w).transpose(), k)) {
        r.indicator(w, k) = indicator.indicator();
        continue;
      }
      const auto update = indicator.push(r.scores(w, k));
      r.indicator(w, k) = update.indicator;
      if (update.started) r.alarms.push_back({k, w, series.windows[w].end_s});
    }
  }
  std::stable_sort(
      r.alarms.begin(), r.alarms.end(),
      [](const DetectionAlarm& a, const DetectionAlarm& b) { return a.window < b.window; });
  return r;
}

Eigen::VectorXd Detector::score_window(WindowFeatures& features,
                                       const Eigen::Ref<const Eigen::MatrixXd>& u,
                                       const Eigen::Ref<const Eigen::MatrixXd>& y,
                                       std::string* skip_reason,
                                       const std::vector<WindowEstimates>& earlier) const {
  std::vector<Eigen::VectorXd> f;
  std::vector<Eigen::MatrixXd> c;
  Eigen::VectorXd h = Eigen::VectorXd::Constant(static_cast<Eigen::Index>(channels_.size()),
                                                std::numeric_limits<double>::quiet_NaN());
  if (!features.extract(u, y, f, skip_reason, &c)) return h;
  for (size_t k = 0; k < channels_.size(); ++k) {
    if (pools(static_cast<int>(k))) {
      if (!f[k].allFinite() || !c[k].allFinite()) continue;  // NaN, as monitor's row
      // Through the same row form as monitor's, so that both score bit-identically.
      const PooledEstimate p = pooled_with(f[k], c[k], earlier, k);
      const Eigen::Index d = p.mean.size();
      const RowMatrixXd row_major = p.covariance;
      h[k] = scorers_[k].score(p.mean, Eigen::Map<const RowMatrixXd>(row_major.data(), d, d));
      continue;
    }
    h[k] = scorers_[k].reference_covariance.size() != 0 ? scorers_[k].score(f[k], c[k])
                                                        : scorers_[k].score(f[k]);
  }
  return h;
}

bool Detector::pools(int k) const {
  return config_.pooled_windows > 1 && channels_[k].kind == MonitoredChannel::Kind::Process &&
         scorers_[k].significance > 0;
}

bool Detector::counts_for_indicator(const Eigen::Ref<const Eigen::VectorXd>& window_scores,
                                    int k) const {
  const MonitoredChannel& c = channels_[k];
  if (c.kind != MonitoredChannel::Kind::Noise || !is_wald(config_.noise_test)) return true;
  for (size_t j = 0; j < channels_.size(); ++j)
    if (channels_[j].kind == MonitoredChannel::Kind::Process && channels_[j].output == c.output &&
        window_scores[static_cast<Eigen::Index>(j)] < 0)
      return false;
  return true;
}

// ------------------------------------------------------------------------------ file format

namespace {

json vector_json(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}
json rows_json(const Eigen::Ref<const Eigen::MatrixXd>& m) {
  json rows = json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) rows.push_back(vector_json(m.row(r).transpose()));
  return rows;
}

// Reads the detector file with every problem named by its JSON path.
class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}
  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw InputError(source_ + ": " + path + ": " + what);
  }
  const json& field(const json& j, const std::string& path, const char* key) const {
    if (!j.is_object()) fail(path, "expected an object");
    auto it = j.find(key);
    if (it == j.end()) fail(path, std::string("missing field '") + key + "'");
    return *it;
  }
  double number(const json& j, const std::string& path) const {
    if (!j.is_number()) fail(path, "expected a number");
    return j.get<double>();
  }
  int integer(const json& j, const std::string& path) const {
    if (!j.is_number_integer()) fail(path, "expected an integer");
    return j.get<int>();
  }
  Eigen::VectorXd vector(const json& j, const std::string& path) const {
    if (!j.is_array()) fail(path, "expected an array of numbers");
    Eigen::VectorXd v(j.size());
    for (size_t k = 0; k < j.size(); ++k) v[k] = number(j[k], path + "[" + std::to_string(k) + "]");
    return v;
  }
  // An array of rows of `cols` numbers each (`rows_required`: at least one row).
  RowMatrixXd matrix(const json& j, const std::string& path, Eigen::Index cols,
                     bool rows_required) const {
    if (!j.is_array() || (rows_required && j.empty()))
      fail(path, "expected a non-empty array of rows");
    RowMatrixXd m(j.size(), cols);
    for (size_t r = 0; r < j.size(); ++r) {
      const std::string pr = path + "[" + std::to_string(r) + "]";
      Eigen::VectorXd row = vector(j[r], pr);
      if (row.size() != cols) fail(pr, "expected " + std::to_string(cols) + " numbers");
      m.row(r) = row.transpose();
    }
    return m;
  }
  const std::string& source() const { return source_; }

 private:
  std::string source_;
};

const char* kind_name(MonitoredChannel::Kind k) {
  return k == MonitoredChannel::Kind::Process ? "process" : "noise";
}

}  // namespace

std::string Detector::to_json() const {
  json channels = json::array();
  for (size_t k = 0; k < channels_.size(); ++k) {
    const MonitoredChannel& c = channels_[k];
    const ChannelScorer& s = scorers_[k];
    json jc{{"kind", kind_name(c.kind)}, {"output", model_.outputs[c.output]}};
    if (c.kind == MonitoredChannel::Kind::Process) jc["input"] = model_.inputs[c.input];
    jc["training_windows"] = s.training_windows;
    jc["outlier_fraction"] = s.outlier_fraction;
    jc["cv_accuracy"] = s.cv_accuracy < 0 ? json(nullptr) : json(s.cv_accuracy);
    jc["feature_mean"] = vector_json(s.feature_mean);
    jc["feature_scale"] = vector_json(s.feature_scale);
    jc["feature_decorrelation"] = rows_json(s.feature_decorrelation);
    jc["reference_covariance"] = rows_json(s.reference_covariance);
    jc["mean_covariance"] = rows_json(s.mean_covariance);
    jc["significance"] = s.significance;
    jc["confirmation"] = s.confirmation;
    jc["model_p_value"] = s.model_p_value < 0 ? json(nullptr) : json(s.model_p_value);
    jc["svm"] = s.significance > 0 ? json(nullptr)
                                   : json{{"kernel_scale", s.kernel_scale},
                                          {"nu", s.nu},
                                          {"n_train", s.n_train},
                                          {"offset", s.offset},
                                          {"dual_coef", vector_json(s.dual_coef)},
                                          {"support_vectors", rows_json(s.support_vectors)}};
    channels.push_back(std::move(jc));
  }
  // nlohmann writes doubles in their shortest round-trip form: a reload scores identically.
  json j{{"format", "mpmpp-detector"},
         {"version", kFormatVersion},
         {"train_end_s", train_end_s_},
         {"config", detail::config_to_json(config_)},
         {"model", json::parse(model_to_json(model_))},
         {"channels", channels}};
  return j.dump(1);
}

Detector Detector::from_json(const std::string& text, const std::string& source) {
  Reader rd(source);
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(source +
                     ": not a complete JSON document (truncated or corrupt file?): " + e.what());
  }
  const json& format = rd.field(j, "(top level)", "format");
  if (!format.is_string() || format.get<std::string>() != "mpmpp-detector")
    rd.fail("format", "not an mpmpp detector file (expected \"mpmpp-detector\")");
  const int version = rd.integer(rd.field(j, "(top level)", "version"), "version");
  if (version < 1 || version > kFormatVersion)
    rd.fail("version", "format version " + std::to_string(version) +
                           " is not supported (this mpmpp reads " + std::to_string(kFormatVersion) +
                           "); upgrade mpmpp or retrain");
  const double train_end_s = rd.number(rd.field(j, "(top level)", "train_end_s"), "train_end_s");
  DetectorConfig config =
      detail::config_from_json(rd.field(j, "(top level)", "config"), source + ": config");
  Model model = parse_model(rd.field(j, "(top level)", "model").dump(), source + ": model");
  const json& jch = rd.field(j, "(top level)", "channels");
  if (!jch.is_array()) rd.fail("channels", "expected an array");
  const std::vector<MonitoredChannel> expected = monitored_channels(model, config);
  if (jch.size() != expected.size())
    rd.fail("channels", std::to_string(jch.size()) + " channels, the model has " +
                            std::to_string(expected.size()) + " monitored channels");
  std::vector<ChannelScorer> scorers;
  for (size_t k = 0; k < jch.size(); ++k) {
    const std::string p = "channels[" + std::to_string(k) + "]";
    const json& c = jch[k];
    const MonitoredChannel& e = expected[k];
    const json& kind = rd.field(c, p, "kind");
    const bool same = kind.is_string() && kind.get<std::string>() == kind_name(e.kind) &&
                      rd.field(c, p, "output") == model.outputs[e.output] &&
                      (e.kind == MonitoredChannel::Kind::Noise ||
                       rd.field(c, p, "input") == model.inputs[e.input]);
    if (!same) rd.fail(p, "does not match the model's channel " + channel_label(model, e));
    ChannelScorer s;
    s.training_windows = rd.integer(rd.field(c, p, "training_windows"), p + ".training_windows");
    s.outlier_fraction = rd.number(rd.field(c, p, "outlier_fraction"), p + ".outlier_fraction");
    const json& cv = rd.field(c, p, "cv_accuracy");
    s.cv_accuracy = cv.is_null() ? -1.0 : rd.number(cv, p + ".cv_accuracy");
    s.feature_mean = rd.vector(rd.field(c, p, "feature_mean"), p + ".feature_mean");
    s.feature_scale = rd.vector(rd.field(c, p, "feature_scale"), p + ".feature_scale");
    const Eigen::Index m = s.feature_mean.size();
    if (version >= 5)  // earlier files predate the Wald test: every channel has an SVM
      s.significance = rd.number(rd.field(c, p, "significance"), p + ".significance");
    if (s.significance <= 0) {
      const std::string ps = p + ".svm";
      const json& svm = rd.field(c, p, "svm");
      s.kernel_scale = rd.number(rd.field(svm, ps, "kernel_scale"), ps + ".kernel_scale");
      s.nu = rd.number(rd.field(svm, ps, "nu"), ps + ".nu");
      s.n_train = rd.integer(rd.field(svm, ps, "n_train"), ps + ".n_train");
      s.offset = rd.number(rd.field(svm, ps, "offset"), ps + ".offset");
      s.dual_coef = rd.vector(rd.field(svm, ps, "dual_coef"), ps + ".dual_coef");
      s.support_vectors =
          rd.matrix(rd.field(svm, ps, "support_vectors"), ps + ".support_vectors", m, true);
    }
    if (version >= 2)  // version 1 files predate it: identity
      s.feature_decorrelation = rd.matrix(rd.field(c, p, "feature_decorrelation"),
                                          p + ".feature_decorrelation", m, false);
    if (version >= 3)  // earlier files predate it: no window-covariance mapping
      s.reference_covariance =
          rd.matrix(rd.field(c, p, "reference_covariance"), p + ".reference_covariance", m, false);
    if (version >= 4)  // earlier files predate it: the training mean taken as exact
      s.mean_covariance =
          rd.matrix(rd.field(c, p, "mean_covariance"), p + ".mean_covariance", m, false);
    if (version >= 10) {  // earlier files predate it: the training mean alone
      s.confirmation = rd.number(rd.field(c, p, "confirmation"), p + ".confirmation");
      const json& mp = rd.field(c, p, "model_p_value");
      s.model_p_value = mp.is_null() ? -1.0 : rd.number(mp, p + ".model_p_value");
    }
    scorers.push_back(std::move(s));
  }
  try {
    return Detector(std::move(model), std::move(config), train_end_s, std::move(scorers));
  } catch (const InputError& e) {
    throw InputError(source + ": " + e.what());
  }
}

void Detector::save(const std::string& path) const { detail::write_file_atomic(path, to_json()); }

Detector Detector::load(const std::string& path) {
  return from_json(detail::read_text_file(path), path);
}

}  // namespace mpmpp
