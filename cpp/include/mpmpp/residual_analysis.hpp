#pragma once
// Residual tests in the style of MATLAB's `resid` and the fit measures of `compare`.
#include <Eigen/Dense>

namespace mpmpp {

// Normalised sample cross-correlation at lags -max_lag..max_lag (index lag + max_lag):
//   r_xy(tau) = sum_t x(t) y(t - tau) / sqrt(sum x^2 sum y^2),
// x and y with their means removed here. With x = residual e and y = input u, positive
// lags are u leading e (a causal effect of u the model misses); in closed loop the negative
// lags mostly reflect feedback (e moves u), not model error. r_xx gives the autocorrelation.
Eigen::VectorXd cross_correlation(const Eigen::Ref<const Eigen::VectorXd>& x,
                                  const Eigen::Ref<const Eigen::VectorXd>& y, int max_lag);

// Half-width of the confidence band of r_xy(tau) under "x and y independent" (Bartlett):
//   z * sqrt(sum_{k=-M..M} r_xx(k) r_yy(k) / N),
// from the two autocorrelations (lags -M..M as returned above). For a white x it is z/sqrt(N).
double correlation_bound(const Eigen::Ref<const Eigen::VectorXd>& r_xx,
                         const Eigen::Ref<const Eigen::VectorXd>& r_yy, Eigen::Index n_samples,
                         double z);

// Fit % = 100 (1 - ||y - yhat|| / ||y - mean y||) in moving windows of `window` samples
// started every `step` samples (window means taken inside each window).
// Returns a (n_windows x 2) matrix: start index, fit %.
Eigen::MatrixXd windowed_fit(const Eigen::Ref<const Eigen::VectorXd>& measured,
                             const Eigen::Ref<const Eigen::VectorXd>& predicted, int window,
                             int step);

double fit_percent(const Eigen::Ref<const Eigen::VectorXd>& measured,
                   const Eigen::Ref<const Eigen::VectorXd>& predicted);

}  // namespace mpmpp
