#pragma once
// The per-window ARX-OE estimate of one output (paper Section 3; MISO per Section 3.3):
//   1. remove the window's mean (optionally a linear trend) from y and every u_j;
//   2. high-order ARX  A(q) y = sum_j q^-d_j B_j(q) u_j + e   (arx.hpp);
//   3. filter y and every u_j with the estimated A(q)          (eq. (9): y_f = A y, u_f = A u);
//   4. output-error fit of all channels jointly on the filtered data, criterion (10) over
//      t >= na (the FIR filter A needs na samples of the window), started from a Prony fit
//      to the impulse response of q^-d_j B_j / A (output_error.hpp).
// Per channel: the parameters, the impulse-response ("FIR") coefficients g_0..g_{L-1} of
// the estimated G_j (sample 0 first, the delay's zeros included: what the SVM compares),
// and the steady-state gain; per output the noise-model coefficients a_1..a_na.
// ArxOeEstimator keeps every workspace between windows: after the first window of a given
// length, estimating another one does not allocate beyond the small result vectors.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "mpmpp/arx.hpp"
#include "mpmpp/output_error.hpp"
#include "mpmpp/transfer_function.hpp"
#include "mpmpp/two_step_covariance.hpp"

namespace mpmpp {

enum class Detrend { None, Mean, Linear };

struct ArxOeConfig {
  ArxOrders arx;                      // na, nb_j, d_j (inputs in the columns' order)
  std::vector<OeChannel> structures;  // G_j structure per input (delay included)
  std::vector<int> fir_length;        // L_j per input (see fir_length_to_one_percent)
  Detrend detrend = Detrend::Mean;
  ArxOptions arx_options;
  OeOptions oe_options;
  // Also compute ArxOeResult::two_step_covariance (FIR structures only; adds about twice
  // the estimate's own time: 0.54 ms to 0.27 ms for a 2 h window of paper MIMO output 3).
  bool two_step_covariance = false;
};

struct ChannelEstimate {
  Eigen::VectorXd b;  // G_j = q^-delay b(q^-1) / f(q^-1)
  Eigen::VectorXd f;  // [1, f_1, ..., f_nf]
  int delay = 0;
  Eigen::VectorXd fir;  // g_0 .. g_{L-1}
  double gain = 0.0;    // G_j(1)
  TransferFunction transfer_function() const { return TransferFunction(b, f, delay); }
};

struct ArxOeResult {
  std::vector<ChannelEstimate> channels;
  Eigen::VectorXd noise;  // a_1 .. a_na of A(q) = 1/H(q)
  ArxResult arx;
  OeResult oe;
  // Covariance of oe.theta with the ARX step's A(q) uncertainty (two_step_covariance.hpp);
  // empty unless ArxOeConfig::two_step_covariance.
  Eigen::MatrixXd two_step_covariance;
};

// One moving window of estimate_windows(): a failed window (missing samples, constant
// input, ...) is flagged with the reason instead of aborting the whole series.
struct WindowEstimate {
  Eigen::Index start = 0;
  bool ok = false;
  std::string message;  // why the window was not estimated (empty when ok)
  ArxOeResult result;
};

class ArxOeEstimator {
 public:
  explicit ArxOeEstimator(ArxOeConfig config);

  // One window (views, e.g. y.segment(start, N), u.middleRows(start, N)). InputError on
  // bad shapes, NumericalError when the window is not informative. stretch_starts: rows
  // where a new complete stretch of a record with gaps begins; every stretch's filters
  // start at rest and its first rows only start them (ArxEstimator, OutputErrorEstimator).
  // The mean is removed over all rows (one operating point); a linear trend or the
  // two-step covariance needs one stretch.
  void estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                const Eigen::Ref<const Eigen::MatrixXd>& u, ArxOeResult& out,
                const std::vector<Eigen::Index>& stretch_starts = {});
  ArxOeResult estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                       const Eigen::Ref<const Eigen::MatrixXd>& u,
                       const std::vector<Eigen::Index>& stretch_starts = {});
  // The first step alone (detrending and the high-order ARX): the noise model A(q) and its
  // covariance without the OE step. Same errors as estimate().
  void estimate_arx(const Eigen::Ref<const Eigen::VectorXd>& y,
                    const Eigen::Ref<const Eigen::MatrixXd>& u, ArxResult& out,
                    const std::vector<Eigen::Index>& stretch_starts = {});
  // Windows [s, s + window) for s = 0, step, 2 step, ... while s + window <= N.
  std::vector<WindowEstimate> estimate_windows(const Eigen::Ref<const Eigen::VectorXd>& y,
                                               const Eigen::Ref<const Eigen::MatrixXd>& u,
                                               Eigen::Index window, Eigen::Index step);

  const ArxOeConfig& config() const { return config_; }

 private:
  ArxOeConfig config_;
  ArxEstimator arx_;
  OutputErrorEstimator oe_;
  TwoStepCovariance two_step_;
  Eigen::VectorXd y_, yf_, pulse_, one_ = Eigen::VectorXd::Ones(1);
  Eigen::MatrixXd u_, uf_;
  std::vector<Eigen::VectorXd> start_impulse_;
  std::vector<detail::RowSpan> stretches_;
};

// Default FIR length: one past the last sample where |g(k)| >= 1% of the peak |g| of the
// nominal impulse response (the delay's leading zeros included). InputError when the
// nominal response is zero or has not decayed within 1,000,000 samples.
int fir_length_to_one_percent(const TransferFunction& nominal);

// g with every integrator divided out: each root of den at z = 1 (a level's inflow-to-level
// channel, a ramp CV of an MPC). An integrating channel filtered from rest never forgets the
// inputs before it, but what it remembers is a constant once its stable part has settled: the
// level every window fit and every disturbance fit carries takes it.
TransferFunction without_integrators(const TransferFunction& g);

// Samples until g's response, filtered from rest, differs from the true one by a constant at
// most: fir_length_to_one_percent of g without its integrators (of g itself when it has none).
int settling_samples(const TransferFunction& g);

// Removes the mean (or the least-squares line a + b t) of x in place.
void detrend_in_place(Eigen::Ref<Eigen::VectorXd> x, Detrend mode);

}  // namespace mpmpp
