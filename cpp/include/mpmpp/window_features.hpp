#pragma once
// What the detector compares, window by window (paper Sections 3 and 4.2): closed-loop
// ARX-OE (arx_oe.hpp) on each moving window, turned into one feature vector per monitored
// channel:
//   process channel G_ij (every channel the nominal model has): the FIR coefficients
//     g_0 .. g_m of the estimated G_ij after the nominal delay (eq. 21), or with
//     ProcessTest::Residual the residual regression's coefficients (also for the channels the
//     model lacks, with DetectorConfig::absent_channels);
//   noise channel H_i (one per output): a_1 .. a_na of the estimated A_i(q) = 1/H_i (Remark 5).
// Each output is one MISO ARX-OE problem over the inputs its model channels use (Sec. 3.3).
// Choices: the ARX uses the paper's order n_b for B_ij, i.e. n_b + 1 coefficients
// b_0..b_nb (eq. 12 writes B = 1 + b_1 q^-1 + ... + b_n q^-n), and the nominal delays;
// the FIR length m + 1 is config.fir_length or, when 0, where the nominal impulse response
// falls below 1% of its peak (fir_length_to_one_percent), so a gain or pole change shows in
// every coefficient the nominal model deems significant.
#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

#include "mpmpp/arx_oe.hpp"
#include "mpmpp/detector_config.hpp"
#include "mpmpp/model.hpp"
#include "mpmpp/residual_regression.hpp"

namespace mpmpp {

// A monitored channel: the process model G_ij (output i <- input j) or the noise model H_i.
struct MonitoredChannel {
  enum class Kind { Process, Noise };
  Kind kind = Kind::Process;
  int output = 0;
  int input = -1;        // -1 for a noise channel
  bool in_model = true;  // false: a channel the model lacks (DetectorConfig::absent_channels)
};

// Every process channel the model has (output-major) and, with config.absent_channels and the
// residual process test, those it lacks in their place; then one noise channel per output.
std::vector<MonitoredChannel> monitored_channels(const Model& model, const DetectorConfig& config);

// One moving window [first, first + window_samples) of a series.
struct FeatureWindow {
  int first = 0;                  // index of its first sample
  double start_s = 0, end_s = 0;  // first sample's time; last sample's time + sample time
  bool skipped = false;           // NaN in the window, or ARX-OE could not estimate
  std::string skip_reason;
};

class WindowFeatures {
 public:
  WindowFeatures(const Model& nominal, const DetectorConfig& config);

  const std::vector<MonitoredChannel>& channels() const { return channels_; }
  int feature_length(int channel) const { return feature_length_[channel]; }
  int window_samples() const { return window_; }
  int step_samples() const { return step_; }

  // One window: u (window_samples x inputs), y (window_samples x outputs), columns in the
  // model's order. Fills features[k] for every channel k and returns true, or returns false
  // with the reason when the window holds a NaN or is not informative (NumericalError of
  // ARX-OE); InputError on wrong shapes. Missing values that a window can do without: under
  // NoiseTest::Residual lost output samples (the residual regression leaves out the rows that
  // read them, a tenth of its rows at most) and lost input samples (held at the last value
  // present, 1 % of an input's samples at most); under the plain ARX-OE of the paper's
  // presets any missing row (fitted on the complete rows, each stretch from rest, a tenth of
  // the window at most).
  // With Resampling::Estimator, `covariances` (when given) receives per channel the OE
  // covariance sigma^2 (J'J)^-1 of features[k] (process channels; the FIR structure makes the
  // OE parameters the features themselves) and a 0 x 0 matrix for noise channels. With
  // ProcessTest::Residual a process channel's features are its residual-regression
  // coefficients (residual_regression.hpp) and `covariances` receives theirs; with
  // NoiseTest::Wald a noise channel's covariance is that of the ARX step's a_1..a_na (the OE
  // step is then not run), with NoiseTest::Residual that of the residual regression's A(q)
  // (no ARX-OE step at all).
  bool extract(const Eigen::Ref<const Eigen::MatrixXd>& u,
               const Eigen::Ref<const Eigen::MatrixXd>& y, std::vector<Eigen::VectorXd>& features,
               std::string* skip_reason = nullptr,
               std::vector<Eigen::MatrixXd>* covariances = nullptr);
  bool has_covariances() const { return process_covariances_ || noise_wald_; }

  // All windows of a series (windows start at 0, step, 2 step, ... while they fit).
  struct Series {
    std::vector<FeatureWindow> windows;
    std::vector<Eigen::MatrixXd>
        features;  // per channel: windows x feature_length, NaN rows when skipped
    // Empty unless has_covariances(): per channel, windows x d^2, each row the window's
    // feature covariance in row-major order; 0 columns for the channels without one (process
    // channels under the SVM without Resampling::Estimator, noise channels under
    // NoiseTest::Svm).
    std::vector<Eigen::MatrixXd> covariances;
  };
  Series extract_series(const Eigen::Ref<const Eigen::VectorXd>& time_s,
                        const Eigen::Ref<const Eigen::MatrixXd>& u,
                        const Eigen::Ref<const Eigen::MatrixXd>& y);

 private:
  struct OutputProblem {
    std::vector<int> inputs;      // model inputs of this output's monitored process channels
    std::vector<int> channels;    // monitored process channel per entry of inputs
    std::vector<int> arx_inputs;  // the inputs of its modelled channels: the ARX-OE problem's
    std::vector<int> skip;        // leading FIR samples (the nominal delay) dropped per input
    int noise_channel = 0;
    ArxOeEstimator estimator;
    Eigen::MatrixXd u;      // window workspace: the columns of inputs
    Eigen::MatrixXd u_arx;  // and of arx_inputs
    // ProcessTest::Residual: the process channels' features come from here (the ARX-OE
    // estimate, or with NoiseTest::Wald its ARX step alone, gives the noise channel's; with
    // NoiseTest::Residual this regression's A(q) does).
    std::optional<ResidualRegression> residual;
  };
  double sample_time_s_;
  int num_inputs_, num_outputs_;
  int window_, step_;
  bool process_covariances_;  // Resampling::Estimator (the OE step's) or ProcessTest::Residual
  bool noise_wald_;           // NoiseTest::Wald: a_1..a_na with their covariance
  bool noise_from_residual_;  // NoiseTest::Residual: A(q) from the residual regression
  // ARX-OE alone (the paper's presets: no residual regression, no covariances): a window with
  // a few missing rows is fitted on its complete rows as stretches, each from rest.
  bool arx_oe_stretches_;
  std::vector<Eigen::Index> complete_rows_, stretch_starts_;  // of the current window
  Eigen::VectorXd y_rows_;
  Eigen::MatrixXd u_rows_;
  std::vector<MonitoredChannel> channels_;
  std::vector<int> feature_length_;
  std::vector<OutputProblem> problems_;
  ArxOeResult result_;
};

}  // namespace mpmpp
