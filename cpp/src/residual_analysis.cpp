#include "mpmpp/residual_analysis.hpp"

#include <cmath>
#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp {

Eigen::VectorXd cross_correlation(const Eigen::Ref<const Eigen::VectorXd>& x,
                                  const Eigen::Ref<const Eigen::VectorXd>& y, int max_lag) {
  const Eigen::Index n = x.size();
  if (y.size() != n) throw InputError("x and y must have the same length");
  if (max_lag < 0 || max_lag >= n)
    throw InputError("max_lag must be in [0, N), got " + std::to_string(max_lag));
  const Eigen::VectorXd xc = x.array() - x.mean();
  const Eigen::VectorXd yc = y.array() - y.mean();
  const double scale = std::sqrt(xc.squaredNorm() * yc.squaredNorm());
  Eigen::VectorXd r = Eigen::VectorXd::Zero(2 * max_lag + 1);
  if (scale == 0.0) return r;
  for (int tau = -max_lag; tau <= max_lag; ++tau) {
    // sum_t x(t) y(t - tau) over the t where both exist.
    const Eigen::Index lo = std::max<Eigen::Index>(0, tau), hi = std::min<Eigen::Index>(n, n + tau);
    r[tau + max_lag] = xc.segment(lo, hi - lo).dot(yc.segment(lo - tau, hi - lo)) / scale;
  }
  return r;
}

double correlation_bound(const Eigen::Ref<const Eigen::VectorXd>& r_xx,
                         const Eigen::Ref<const Eigen::VectorXd>& r_yy, Eigen::Index n_samples,
                         double z) {
  if (r_xx.size() != r_yy.size()) throw InputError("r_xx and r_yy must have the same lags");
  if (n_samples <= 0) throw InputError("n_samples must be > 0");
  const double p = r_xx.dot(r_yy);
  return z * std::sqrt(std::max(p, 0.0) / static_cast<double>(n_samples));
}

double fit_percent(const Eigen::Ref<const Eigen::VectorXd>& measured,
                   const Eigen::Ref<const Eigen::VectorXd>& predicted) {
  if (measured.size() != predicted.size())
    throw InputError("measured and predicted must have the same length");
  const double spread = (measured.array() - measured.mean()).matrix().norm();
  if (spread == 0.0) return std::nan("");
  return 100.0 * (1.0 - (measured - predicted).norm() / spread);
}

Eigen::MatrixXd windowed_fit(const Eigen::Ref<const Eigen::VectorXd>& measured,
                             const Eigen::Ref<const Eigen::VectorXd>& predicted, int window,
                             int step) {
  if (measured.size() != predicted.size())
    throw InputError("measured and predicted must have the same length");
  if (window < 2) throw InputError("window must be >= 2 samples");
  if (step < 1) throw InputError("step must be >= 1 sample");
  const Eigen::Index n = measured.size();
  const Eigen::Index count = n >= window ? (n - window) / step + 1 : 0;
  Eigen::MatrixXd out(count, 2);
  for (Eigen::Index w = 0; w < count; ++w) {
    const Eigen::Index s = w * step;
    out(w, 0) = static_cast<double>(s);
    out(w, 1) = fit_percent(measured.segment(s, window), predicted.segment(s, window));
  }
  return out;
}

}  // namespace mpmpp
