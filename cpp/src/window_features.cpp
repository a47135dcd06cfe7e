#include "mpmpp/window_features.hpp"

#include <cmath>
#include <limits>

#include "mpmpp/error.hpp"

namespace mpmpp {

std::vector<MonitoredChannel> monitored_channels(const Model& model, const DetectorConfig& config) {
  const bool monitors_absent =
      config.absent_channels > 0 && config.process_test == ProcessTest::Residual;
  std::vector<MonitoredChannel> channels;
  for (int i = 0; i < model.num_outputs(); ++i)
    for (int j = 0; j < model.num_inputs(); ++j)
      if (model.acts(i, j) || monitors_absent)
        channels.push_back({MonitoredChannel::Kind::Process, i, j, model.acts(i, j)});
  for (int i = 0; i < model.num_outputs(); ++i)
    channels.push_back({MonitoredChannel::Kind::Noise, i, -1});
  return channels;
}

namespace {

// A time step this many sample times away from one is a break in the record (a split, or rows
// left out): jitter of a timestamp is not, the data reader snaps it (data_io.cpp).
constexpr double kBreakStep = 0.5;

// Symmetrised bit for bit, so that batch (row-major copy) and streaming scores agree.
Eigen::MatrixXd symmetrised(const Eigen::Ref<const Eigen::MatrixXd>& m) {
  return 0.5 * (m + m.transpose());
}

ArxOeConfig output_problem_config(const Model& model, const DetectorConfig& config, int i,
                                  const std::vector<int>& inputs,
                                  std::vector<int>& fir_after_delay) {
  ArxOeConfig c;
  c.arx.na = config.arx_order_a;
  c.detrend = Detrend::Mean;
  c.arx_options.delta = config.arx_regularisation;
  // Estimator resampling weighs each window by its FIR estimate's covariance, which must
  // include the ARX step's A(q) uncertainty: without it output 3's G32 spread is half
  // the real one in the paper MIMO example (docs/detection.md).
  // (With ProcessTest::Residual the process channels' covariances come from the residual
  // regression: the OE covariance would go unused.)
  c.two_step_covariance =
      config.resampling == Resampling::Estimator && config.process_test != ProcessTest::Residual;
  for (int j : inputs) {
    const TransferFunction& g = *model.process[i][j];
    const int d = g.delay();
    c.arx.nb.push_back(config.arx_order_b + 1);  // b_0..b_nb: paper order n_b
    c.arx.delays.push_back(d);
    // FIR length with the delay's leading zeros (what ArxOeEstimator returns).
    // The residual test takes no FIR features, so an integrating channel (whose impulse
    // response never decays) is cut where its stable part has settled.
    const int length = config.fir_length > 0 ? d + config.fir_length
                       : config.process_test == ProcessTest::Residual
                           ? settling_samples(g)
                           : fir_length_to_one_percent(g);
    fir_after_delay.push_back(length - d);
    c.fir_length.push_back(length);
    c.structures.push_back(config.oe_structure == OeStructure::Foptd
                               ? OeChannel::foptd(d)
                               : OeChannel::fir(length - d, d));
  }
  return c;
}

}  // namespace

WindowFeatures::WindowFeatures(const Model& nominal, const DetectorConfig& config)
    : sample_time_s_(nominal.sample_time_s),
      num_inputs_(nominal.num_inputs()),
      num_outputs_(nominal.num_outputs()),
      process_covariances_(config.resampling == Resampling::Estimator ||
                           config.process_test == ProcessTest::Residual),
      noise_wald_(is_wald(config.noise_test)),
      noise_from_residual_(config.noise_test == NoiseTest::Residual),
      arx_oe_stretches_(!process_covariances_ && !noise_wald_ && !noise_from_residual_) {
  config.validate();
  config.check_whitening_entries(num_outputs_);
  window_ = config.window_samples(nominal.sample_time_s);
  step_ = config.step_samples(nominal.sample_time_s);
  channels_ = monitored_channels(nominal, config);
  feature_length_.assign(channels_.size(), 0);
  for (int i = 0; i < num_outputs_; ++i) {
    std::vector<int> inputs, channels, arx_inputs;
    for (size_t k = 0; k < channels_.size(); ++k)
      if (channels_[k].kind == MonitoredChannel::Kind::Process && channels_[k].output == i) {
        inputs.push_back(channels_[k].input);
        channels.push_back(static_cast<int>(k));
        if (channels_[k].in_model) arx_inputs.push_back(channels_[k].input);
      }
    if (arx_inputs.empty())
      throw InputError("detector: output '" + nominal.outputs[i] +
                       "' has no process channel in the model; nothing to monitor it against");
    // The ARX-OE problem is over the modelled channels; without absent channels (the SVM paths
    // allow none) its entry e is monitored channel channels[e].
    std::vector<int> fir_after_delay;
    ArxOeConfig c = output_problem_config(nominal, config, i, arx_inputs, fir_after_delay);
    for (size_t e = 0; e < fir_after_delay.size(); ++e)
      feature_length_[channels[e]] = fir_after_delay[e];
    int noise_channel = 0;
    for (size_t k = 0; k < channels_.size(); ++k)
      if (channels_[k].kind == MonitoredChannel::Kind::Noise && channels_[k].output == i)
        noise_channel = static_cast<int>(k);
    feature_length_[noise_channel] = config.arx_order_a;
    std::optional<ResidualRegression> residual;
    if (config.process_test == ProcessTest::Residual) {
      residual.emplace(nominal, i, inputs, config);
      for (size_t e = 0; e < inputs.size(); ++e)
        feature_length_[channels[e]] = residual->block_size(static_cast<int>(e));
      if (noise_from_residual_) feature_length_[noise_channel] = residual->ar_order();
    }
    const std::vector<int> skip(c.arx.delays);
    problems_.push_back(OutputProblem{
        inputs, channels, arx_inputs, skip, noise_channel, ArxOeEstimator(std::move(c)),
        Eigen::MatrixXd(window_, static_cast<Eigen::Index>(inputs.size())),
        Eigen::MatrixXd(window_, static_cast<Eigen::Index>(arx_inputs.size())),
        std::move(residual)});
  }
}

bool WindowFeatures::extract(const Eigen::Ref<const Eigen::MatrixXd>& u,
                             const Eigen::Ref<const Eigen::MatrixXd>& y,
                             std::vector<Eigen::VectorXd>& features, std::string* skip_reason,
                             std::vector<Eigen::MatrixXd>* covariances) {
  if (u.rows() != window_ || y.rows() != window_ || u.cols() != num_inputs_ ||
      y.cols() != num_outputs_)
    throw InputError("detector: a window must be " + std::to_string(window_) + " samples of " +
                     std::to_string(num_inputs_) + " inputs and " + std::to_string(num_outputs_) +
                     " outputs, got u " + std::to_string(u.rows()) + "x" +
                     std::to_string(u.cols()) + ", y " + std::to_string(y.rows()) + "x" +
                     std::to_string(y.cols()));
  // docs/formats.md forbids interpolating missing values. The residual regression alone
  // (NoiseTest::Residual) leaves out the rows that read a lost output sample and holds a lost
  // input sample at the last value present (ResidualRegression::estimate, within its limits);
  // the plain ARX-OE fits the complete rows as stretches while at most a tenth of the window is
  // missing. Otherwise a gap makes the window unusable.
  complete_rows_.clear();
  stretch_starts_.clear();
  if (!u.allFinite() || !y.allFinite()) {
    if (arx_oe_stretches_) {
      for (Eigen::Index t = 0; t < window_; ++t) {
        if (!u.row(t).allFinite() || !y.row(t).allFinite()) continue;
        if (!complete_rows_.empty() && complete_rows_.back() != t - 1)
          stretch_starts_.push_back(static_cast<Eigen::Index>(complete_rows_.size()));
        complete_rows_.push_back(t);
      }
    }
    const bool stretches = arx_oe_stretches_ && static_cast<Eigen::Index>(complete_rows_.size()) >=
                                                    window_ - window_ / 10;
    if (!noise_from_residual_ && !stretches) {
      if (skip_reason) *skip_reason = "missing values in the window";
      return false;
    }
  }
  features.resize(channels_.size());
  const bool want_covariances = has_covariances() && covariances != nullptr;
  if (want_covariances) covariances->assign(channels_.size(), Eigen::MatrixXd());
  for (auto& p : problems_) {
    const int i = channels_[p.noise_channel].output;
    for (size_t e = 0; e < p.inputs.size(); ++e) p.u.col(e) = u.col(p.inputs[e]);
    // NoiseTest::Residual: A(q) comes from the residual regression, no ARX-OE step is needed;
    // with the residual process test and NoiseTest::Wald the ARX step alone gives A(q).
    if (!noise_from_residual_) {
      for (size_t e = 0; e < p.arx_inputs.size(); ++e) p.u_arx.col(e) = u.col(p.arx_inputs[e]);
      try {
        if (p.residual && noise_wald_) {
          p.estimator.estimate_arx(y.col(i), p.u_arx, result_.arx);
        } else if (complete_rows_.empty()) {
          p.estimator.estimate(y.col(i), p.u_arx, result_);
        } else {
          y_rows_ = y.col(i)(complete_rows_);
          u_rows_ = p.u_arx(complete_rows_, Eigen::all);
          p.estimator.estimate(y_rows_, u_rows_, result_, stretch_starts_);
        }
      } catch (const NumericalError& err) {
        if (skip_reason) *skip_reason = err.what();
        return false;
      }
      const Eigen::Index na = feature_length_[p.noise_channel];
      features[p.noise_channel] = result_.arx.a.tail(na);  // a_1..a_na of A(q) = 1/H (Remark 5)
      if (noise_wald_ && want_covariances) {
        const auto block = result_.arx.covariance.topLeftCorner(na, na);
        (*covariances)[p.noise_channel] = symmetrised(block);
      }
    }
    if (p.residual) {
      std::vector<Eigen::VectorXd> beta;
      std::vector<Eigen::MatrixXd> beta_covariance;
      Eigen::VectorXd ar;
      Eigen::MatrixXd ar_covariance;
      if (!p.residual->estimate(y.col(i), p.u, beta, beta_covariance, skip_reason,
                                noise_from_residual_ ? &ar : nullptr,
                                noise_from_residual_ ? &ar_covariance : nullptr))
        return false;
      if (noise_from_residual_) {
        features[p.noise_channel] = ar;
        if (want_covariances) (*covariances)[p.noise_channel] = symmetrised(ar_covariance);
      }
      for (size_t e = 0; e < p.inputs.size(); ++e) {
        features[p.channels[e]] = beta[e];
        if (want_covariances) (*covariances)[p.channels[e]] = symmetrised(beta_covariance[e]);
      }
      continue;
    }
    Eigen::Index offset = 0;  // channel e's block of the OE parameter vector (FIR structure)
    for (size_t e = 0; e < p.inputs.size(); ++e) {
      const Eigen::VectorXd& g = result_.channels[e].fir;
      features[p.channels[e]] = g.tail(g.size() - p.skip[e]);
      const Eigen::Index d = features[p.channels[e]].size();
      if (want_covariances && process_covariances_)
        (*covariances)[p.channels[e]] =
            symmetrised(result_.two_step_covariance.block(offset, offset, d, d));
      offset += d;
    }
  }
  return true;
}

WindowFeatures::Series WindowFeatures::extract_series(
    const Eigen::Ref<const Eigen::VectorXd>& time_s, const Eigen::Ref<const Eigen::MatrixXd>& u,
    const Eigen::Ref<const Eigen::MatrixXd>& y) {
  const Eigen::Index n = time_s.size();
  if (u.rows() != n || y.rows() != n)
    throw InputError("detector: time, u and y must have the same number of samples (" +
                     std::to_string(n) + ", " + std::to_string(u.rows()) + ", " +
                     std::to_string(y.rows()) + ")");
  Series s;
  const int count = n >= window_ ? static_cast<int>((n - window_) / step_) + 1 : 0;
  s.windows.resize(count);
  for (size_t k = 0; k < channels_.size(); ++k) {
    s.features.emplace_back(count, feature_length_[k]);
    if (has_covariances()) {
      const bool process = channels_[k].kind == MonitoredChannel::Kind::Process;
      const bool covariance = process ? process_covariances_ : noise_wald_;
      s.covariances.emplace_back(count, covariance ? feature_length_[k] * feature_length_[k] : 0);
    }
  }
  // breaks[t]: time steps up to row t that are not one sample time. load_data marks a split of
  // the record with one missing row and starts the next segment on a grid of its own; the
  // missing row alone reads as a lost sample, the step after it tells the break.
  std::vector<int> breaks(static_cast<size_t>(n), 0);
  for (Eigen::Index t = 1; t < n; ++t)
    breaks[t] = breaks[t - 1] + (std::abs(time_s[t] - time_s[t - 1] - sample_time_s_) >
                                 kBreakStep * sample_time_s_);
  std::vector<Eigen::VectorXd> f;
  std::vector<Eigen::MatrixXd> c;
  for (int w = 0; w < count; ++w) {
    FeatureWindow& win = s.windows[w];
    win.first = w * step_;
    win.start_s = time_s[win.first];
    win.end_s = time_s[win.first + window_ - 1] + sample_time_s_;
    if (breaks[win.first + window_ - 1] != breaks[win.first]) {
      win.skipped = true;
      win.skip_reason = "a break between segments in the window";
    } else {
      win.skipped = !extract(u.middleRows(win.first, window_), y.middleRows(win.first, window_), f,
                             &win.skip_reason, &c);
    }
    for (size_t k = 0; k < channels_.size(); ++k) {
      if (win.skipped) {
        s.features[k].row(w).setConstant(std::numeric_limits<double>::quiet_NaN());
        if (has_covariances())
          s.covariances[k].row(w).setConstant(std::numeric_limits<double>::quiet_NaN());
        continue;
      }
      s.features[k].row(w) = f[k].transpose();
      if (has_covariances() && c[k].size() != 0)  // symmetric: row- and column-major agree
        s.covariances[k].row(w) = Eigen::Map<const Eigen::RowVectorXd>(c[k].data(), c[k].size());
    }
  }
  return s;
}

}  // namespace mpmpp
