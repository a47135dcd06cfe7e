#pragma once
// The nominal model's output error regressed on directions of model change (the "residual"
// process test of the recommended presets, DetectorConfig::process_test).
//
// For output i with nominal channels G0_ij, v = y_i - sum_j G0_ij u_j. With the model right,
// v = H e is the disturbance alone; in closed loop the inputs' past is driven by e's past but
// never by e(t), so after whitening v by its own AR polynomial A(q) no lagged input explains
// any of it. With G_ij = G0_ij + dG_ij, v gains dG_ij u_j. So per window (Ljung's residual
// cross-correlation test made a regression, the Box-Jenkins pseudo-linear step):
//   A(q) v(t) = sum_j beta_j' A(q) x_j(t) + c0 + c1 t + e(t),
// x_j = the directions in which G_ij can change, all lagged at least one sample (u(t) may
// react to y(t), docs/formats.md's timing):
//   G0_ij u_j at the nominal delay d (gain), then at d + 1 and d - 1 (d + 2 when d = 1: the
//   dead time);
//   laguerre_terms Laguerre filters of u_j from lag 1, with the channel's slowest pole
//   (time constant and any other shape).
// With a moving-average root c (residual_ma_roots[output], from the training: a wandering
// disturbance), v and x_j first pass 1 / (1 - c q^-1).
// A(q) (order residual_ar_orders[output], else residual_ar_order, else arx_order_a; with a level
// and a ramp for drifting disturbances) and beta are estimated alternately (two passes). Its
// order must stay near the disturbance's: under feedback alone the inputs are filtered output
// errors, so a long A(q) can predict dG u from v's past and absorb a process change into the
// noise model (docs/detection.md "The whitening order"). An unmeasured step or ramp
// disturbance inside the window is neither: the AR fit explains it with a root near 1, which
// over-differences the rest of the disturbance, and the controller's moves against it are in
// x_j, so beta is biased. Both fits therefore take up to residual_steps breaks, greedily: a
// level shift 1{t >= k} and a hinge max(0, t - k) together at the row k where their
// chi-square(2) score on the fit's residual peaks, kept while it passes step_significance /
// (rows scanned) (Bonferroni). An isolated outlier (a spike in y) enters na + 1 rows of every
// fit; with outlier_sigmas those rows are left out: those reading a sample whose innovation in a
// first AR fit exceeds that many robust sigmas, unless more than a tenth of the rows would go.
// beta_j and its covariance sigma^2
// (Z'Z)^-1 are the channel's features; the Detector compares them with the training period's in a
// Wald test (detector.hpp, ChannelScorer::significance). A disturbance change moves only A(q) and
// sigma^2, which the window re-estimates, so it does not move beta: no MPM alarm for a noise
// change. Near-collinear directions (a smooth input, a Laguerre pole at the model's own) are
// handled by a truncated SVD of the column-scaled regressors.
// A channel the model lacks (DetectorConfig::absent_channels) has G0 = 0 and only the Laguerre
// directions, in the slowest time scale of the output's modelled channels and from the lag of
// the fastest of them: a coupling that appears is then beta_j != 0 on a channel of its own.
#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

#include "mpmpp/detector_config.hpp"
#include "mpmpp/model.hpp"
#include "mpmpp/transfer_function.hpp"

namespace mpmpp {

class ResidualRegression {
 public:
  // Output `output` of `nominal`, regressed on the channels from `inputs` (each a channel the
  // model has, or with config.absent_channels one it lacks). InputError when an input has no
  // channel and absent channels are not monitored.
  ResidualRegression(const Model& nominal, int output, std::vector<int> inputs,
                     const DetectorConfig& config);

  int block_size(int e) const { return static_cast<int>(directions_[e].size()); }
  // Leading samples of a window used only to let the filters settle (zero initial state).
  int settling_samples() const { return settle_; }

  // y: the output's samples, u: one column per entry of `inputs`. Fills beta[e] and
  // covariance[e] per input, and when asked the whitening A(q) = 1 + ar_1 q^-1 + ... (the
  // disturbance model 1/H, NoiseTest::Residual) with its covariance; false (with the reason) when
  // the window is too short or the whitened regressors carry no information.
  bool estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                const Eigen::Ref<const Eigen::MatrixXd>& u, std::vector<Eigen::VectorXd>& beta,
                std::vector<Eigen::MatrixXd>& covariance, std::string* reason = nullptr,
                Eigen::VectorXd* ar = nullptr, Eigen::MatrixXd* ar_covariance = nullptr) const;
  int ar_order() const { return ar_order_; }

 private:
  std::vector<std::optional<TransferFunction>> nominal_;   // G0_ij per input, none if absent
  std::vector<std::vector<TransferFunction>> directions_;  // x_j = directions_[e][k] u_j
  int ar_order_;
  double ma_root_;  // c of the training disturbance's (1 - c q^-1): v and x_j pass 1 / (1 - c q^-1)
  int settle_;
  int max_steps_;
  double step_significance_;
  double outlier_sigmas_;
};

}  // namespace mpmpp
