#pragma once
// Moving-window model-plant mismatch (MPM) and noise-change detector (paper Sections 2, 4).
//
// A Detector holds, per monitored channel (window_features.hpp: every process channel of the
// nominal model, and the noise model of every output), the trained one-class SVM that bounds
// the "normal" cluster of estimates from the training period, with the feature
// standardisation it was trained in. train_detector (detector_training.hpp) builds it from
// the training windows; everything a plant needs afterwards is here:
//   * score_window: ARX-OE on one window -> SVM score h(x) per channel (eq. 20, paper scale);
//   * monitor: every window of a series -> scores (0 inside the training period, as in the
//     paper's Figs 4, 7, 8; NaN for skipped windows), the indicator of eq. 23 and the
//     alarms per channel (mismatch_indicator.hpp) with their start times;
//   * save / load: a versioned JSON file ("format": "mpmpp-detector", "version":
//     kFormatVersion; CHANGELOG.md "File formats" lists the versions, all of which load),
//     written atomically; a missing, truncated, corrupt or newer file is a clear InputError.
// The streaming front end (streaming_detector.hpp) is WindowFeatures + ChannelScorer +
// MismatchIndicator.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "mpmpp/detector_config.hpp"
#include "mpmpp/eigen_types.hpp"
#include "mpmpp/model.hpp"
#include "mpmpp/window_features.hpp"

namespace mpmpp {

// log p of the Wald test of `deviation` ~ N(0, covariance): T = deviation' covariance^+
// deviation against chi-square(rank), the pseudo-inverse and rank taken in correlation form
// with ChannelScorer::kWaldRankTolerance; NaN when no direction has variance.
double wald_log_p_value(const Eigen::Ref<const Eigen::VectorXd>& deviation,
                        const Eigen::Ref<const Eigen::MatrixXd>& covariance);

// The trained SVM of one channel and the standardisation of its features:
// z = D ((x - feature_mean) / feature_scale),  h(x) = (sum_i dual_coef_i k(sv_i, z) - offset) / (nu
// l) (eq. 20 in the paper's scaling: same sign as scikit-learn's decision_function), with D =
// feature_decorrelation (lower triangular, the inverse Cholesky factor of the resampled
// coefficients' correlation matrix, Resampling::Covariance) or the identity when it is empty.
struct ChannelScorer {
  Eigen::VectorXd feature_mean, feature_scale;
  Eigen::MatrixXd feature_decorrelation;  // empty or m x m
  RowMatrixXd support_vectors;            // in the standardised space
  Eigen::VectorXd dual_coef;              // libsvm scaling, in (0, 1]
  double offset = 0;                      // libsvm scaling, after the outlier-fraction shift
  double kernel_scale = 1;                // c of eq. 15
  double nu = 0.5;
  int n_train = 0;  // l: resampled models the SVM was fitted on
  // Training report (not needed to score).
  int training_windows = 0;
  double outlier_fraction = 0;
  double cv_accuracy = -1;  // -1: the outlier fraction was fixed, not cross-validated

  // Resampling::Estimator (else empty): C_ref, the mean OE covariance of the training
  // windows' features (d x d). A monitored window's deviation is first carried into the
  // training windows' precision, x <- feature_mean + C_ref^1/2 C^-1/2 (x - feature_mean), C the
  // window's own OE covariance (symmetric square roots). With no change x - mean ~ N(0, C), so
  // the mapped deviation ~ N(0, C_ref) like the training estimates: a window estimated less
  // precisely (a noise change that leaves the A-filtered inputs less informative) is not taken
  // for a process change, and a more precise one shows a real change more clearly.
  Eigen::MatrixXd reference_covariance;
  // Resampling::Estimator (else empty): C_mean, the covariance of feature_mean itself. The
  // training mean averages only a few independent windows (8 h of 2 h windows), so a new
  // window's deviation x - mean has covariance C + C_mean, not C; score(x, C) whitens by
  // (C + C_mean)^-1/2, and training sets reference_covariance = C_ref + C_mean so that a
  // window like the training ones maps to itself. Without it, a channel whose estimates turn
  // collinear after training (paper MIMO G32 after the H22 change: coefficient correlation
  // -0.93 -> -0.99) sees the mean's error as a change in its thin direction (mean squared
  // Mahalanobis distance per coefficient 2.5 instead of 1 over 30 seeds; 1.0 with C_mean).
  Eigen::MatrixXd mean_covariance;
  // Wald-test channels (ProcessTest::Residual process channels, Wald noise
  // channels; else 0): the window level of the Wald test that replaces the SVM.
  // T = (x - mean)' (C + C_mean)^+ (x - mean) ~ chi-square(rank) with no change,
  // p = P(chi-square > T) (wald_log_p_value: log p, finite where p underflows), and the score
  // is log10(p / significance): negative (a mismatch window, eq. 22's sign) when
  // p < significance, like h(x) < 0 for the SVM.
  // (A union of nested gain / gain-and-dead-time / full tests with a Bonferroni correction
  // was tried: tuning families, seeds 0-19, it detected fewer changes, 15/35 against 18/35.)
  double significance = 0;
  // Wald-test process channels whose training agreed with the model
  // (DetectorConfig::model_reference_significance; else 0): the window is also tested against
  // the model, beta = 0 with no reference variance, T_0 = x' C^+ x. Intersection-union test:
  // the window is negative only when both reject, p_0 < significance and p < confirmation, so
  // its score is log10 max(p_0 / significance, p / confirmation). The model as reference adds
  // the power the training mean's variance takes; the confirmation keeps an alarm a change
  // since training (a model error the training could not resolve stays out of it).
  double confirmation = 0;
  // Training report: p of the training's pooled coefficients against the model (-1: not tested).
  double model_p_value = -1;
  static constexpr double kWaldRankTolerance = 1e-9;  // eigenvalues of the correlation form
  // log p of the Wald test of x against feature_mean (covariance window + mean_covariance).
  double wald_log_p_value(const Eigen::Ref<const Eigen::VectorXd>& x,
                          const Eigen::Ref<const Eigen::MatrixXd>& window_covariance) const;

  // score(x) for channels without reference_covariance (InputError otherwise); score(x, C)
  // takes the window's covariance (ignored without reference_covariance; NaN when C is not
  // positive definite: the window carries no usable evidence).
  double score(const Eigen::Ref<const Eigen::VectorXd>& x) const;
  double score(const Eigen::Ref<const Eigen::VectorXd>& x,
               const Eigen::Ref<const Eigen::MatrixXd>& window_covariance) const;
  // NaN rows -> NaN. covariances: windows x d^2 (row-major rows, WindowFeatures::Series),
  // required with reference_covariance.
  Eigen::VectorXd score_rows(
      const Eigen::Ref<const Eigen::MatrixXd>& X,
      const Eigen::Ref<const Eigen::MatrixXd>& covariances = Eigen::MatrixXd()) const;
  void validate(int feature_length, const std::string& where) const;  // InputError on bad shapes
};

// One window's estimates per channel (WindowFeatures::extract); empty when the window is missing
// or was skipped.
struct WindowEstimates {
  std::vector<Eigen::VectorXd> features;
  std::vector<Eigen::MatrixXd> covariances;
};

struct DetectionAlarm {
  int channel = 0;     // index into channels
  int window = 0;      // the window at which the indicator first reached s_T
  double start_s = 0;  // that window's end time
};

struct DetectionResult {
  std::vector<MonitoredChannel> channels;
  std::vector<FeatureWindow> windows;
  std::vector<bool> training;          // per window: ends inside the training period (scores 0)
  Eigen::MatrixXd scores;              // windows x channels
  Eigen::MatrixXd indicator;           // windows x channels, eq. 23
  std::vector<DetectionAlarm> alarms;  // in window order, then channel order
};

class Detector {
 public:
  // scorers[k] belongs to monitored_channels(nominal, config)[k]. train_end_s is counted from the
  // first sample of a monitored series: windows ending at or before time_s[0] + train_end_s
  // are training windows.
  Detector(Model nominal, DetectorConfig config, double train_end_s,
           std::vector<ChannelScorer> scorers);

  // Every window of (time_s, u, y): ARX-OE features, scores, indicator, alarms.
  DetectionResult monitor(const Eigen::Ref<const Eigen::VectorXd>& time_s,
                          const Eigen::Ref<const Eigen::MatrixXd>& u,
                          const Eigen::Ref<const Eigen::MatrixXd>& y) const;
  // The same from features already extracted (the training run reuses its ARX-OE estimates).
  DetectionResult monitor(const WindowFeatures::Series& series) const;

  // One window (window_samples rows): score per channel; all NaN when the window is skipped.
  // `features` (from make_features()) is the caller's ARX-OE workspace, reused across windows.
  // `earlier`: the estimates of the windows 1, 2, ... pooling lags before it
  // (DetectorConfig::pooled_windows; unused when it is 1).
  Eigen::VectorXd score_window(WindowFeatures& features, const Eigen::Ref<const Eigen::MatrixXd>& u,
                               const Eigen::Ref<const Eigen::MatrixXd>& y,
                               std::string* skip_reason = nullptr,
                               const std::vector<WindowEstimates>& earlier = {}) const;
  // Whether channel k's test pools disjoint windows (pooled_windows > 1, a Wald-test process
  // channel), and how many windows apart they are at the model's sample time.
  bool pools(int k) const;
  int pooling_lag() const { return config_.pooling_lag(model_.sample_time_s); }
  // Whether channel k's window, with these scores, is evidence for its indicator (eq. 23).
  // Always, except that with a Wald noise test a noise channel's window is passed over (the
  // indicator and alarm keep their state) while a process channel of its output is negative
  // in it. A window straddling a process change leaves in the ARX's A(q) what one B(q)
  // cannot fit on both sides; the Wald test, precise to a few percent of a coefficient, then
  // flags a noise change that did not happen (paper MIMO, seeds 0-19: a noise alarm on
  // press_dry_weight at every G11 doubling). Passing over, not counting as normal, keeps an
  // earlier, real noise alarm standing through a later process change.
  bool counts_for_indicator(const Eigen::Ref<const Eigen::VectorXd>& window_scores, int k) const;

  const Model& model() const { return model_; }
  const DetectorConfig& config() const { return config_; }
  double train_end_s() const { return train_end_s_; }
  const std::vector<MonitoredChannel>& channels() const { return channels_; }
  const std::vector<ChannelScorer>& scorers() const { return scorers_; }
  // A fresh feature extractor for this detector's model and config (own workspace).
  WindowFeatures make_features() const { return WindowFeatures(model_, config_); }

  std::string to_json() const;
  // `source` names the text in error messages (the file path for load).
  static Detector from_json(const std::string& text, const std::string& source);
  void save(const std::string& path) const;  // atomic: temporary file + rename
  static Detector load(const std::string& path);

  static constexpr int kFormatVersion = 12;  // history in CHANGELOG.md, "File formats"

 private:
  Model model_;
  DetectorConfig config_;
  double train_end_s_;
  std::vector<ChannelScorer> scorers_;
  std::vector<MonitoredChannel> channels_;
};

// Short channel name for messages, tables and plots: "G[y <- u]" for a process channel,
// "H[y]" for a noise channel (input empty).
std::string channel_label(const std::string& output, const std::string& input);
std::string channel_label(const Model& model, const MonitoredChannel& channel);

}  // namespace mpmpp
