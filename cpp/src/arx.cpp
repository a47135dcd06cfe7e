#include "mpmpp/arx.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "mpmpp/error.hpp"
#include "order_limits.hpp"

namespace mpmpp {

namespace {
void require_informative_signal(const Eigen::Ref<const Eigen::VectorXd>& x,
                                const std::string& name) {
  if (x.size() == 0) throw NumericalError("window not informative: " + name + " has no samples");
  // The sum is finite iff every sample is (short of overflow): one vectorised pass.
  if (!std::isfinite(x.sum()))
    if (const auto k = (!x.array().isFinite()).count(); k > 0)
      throw NumericalError("window not informative: " + name + " has " + std::to_string(k) +
                           " non-finite samples of " + std::to_string(x.size()));
  const double hi = x.maxCoeff(), lo = x.minCoeff();
  if (hi - lo <= 1e-12 * std::max(std::abs(hi), std::abs(lo)))
    throw NumericalError("window not informative: " + name + " is constant over the window");
}
}  // namespace

void require_informative_window(const Eigen::Ref<const Eigen::VectorXd>& y,
                                const Eigen::Ref<const Eigen::MatrixXd>& u) {
  require_informative_signal(y, "y");
  for (Eigen::Index j = 0; j < u.cols(); ++j)
    require_informative_signal(u.col(j), "u[" + std::to_string(j) + "]");
}

ArxEstimator::ArxEstimator(ArxOrders orders, ArxOptions options)
    : orders_(std::move(orders)), options_(options) {
  const std::size_t m = orders_.nb.size();
  if (orders_.na < 0) throw InputError("na must be >= 0, got " + std::to_string(orders_.na));
  if (orders_.na > detail::kMaxLag)
    throw InputError("na must be <= 1000000, got " + std::to_string(orders_.na));
  if (m == 0) throw InputError("nb must name at least one input");
  if (orders_.delays.size() != m)
    throw InputError("delays must have one entry per input (" + std::to_string(m) + "), got " +
                     std::to_string(orders_.delays.size()));
  if (!(options_.delta >= 0.0)) throw InputError("delta must be >= 0");
  if (!(options_.rank_tolerance >= 0.0)) throw InputError("rank_tolerance must be >= 0");
  t0_ = orders_.na;
  p_ = orders_.na;
  for (std::size_t j = 0; j < m; ++j) {
    if (orders_.nb[j] < 1)
      throw InputError("nb[" + std::to_string(j) + "] must be >= 1, got " +
                       std::to_string(orders_.nb[j]));
    if (orders_.nb[j] > detail::kMaxLag)
      throw InputError("nb[" + std::to_string(j) + "] must be <= 1000000, got " +
                       std::to_string(orders_.nb[j]));
    if (orders_.delays[j] > detail::kMaxLag)
      throw InputError("delays[" + std::to_string(j) + "] must be <= 1000000, got " +
                       std::to_string(orders_.delays[j]));
    if (orders_.delays[j] < 0)
      throw InputError("delays[" + std::to_string(j) + "] must be >= 0, got " +
                       std::to_string(orders_.delays[j]));
    t0_ = std::max<Eigen::Index>(t0_, Eigen::Index{orders_.delays[j]} + orders_.nb[j] - 1);
    p_ += orders_.nb[j];
  }
  columns_.resize(static_cast<std::size_t>(p_));
}

void ArxEstimator::estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                            const Eigen::Ref<const Eigen::MatrixXd>& u, ArxResult& out,
                            const std::vector<Eigen::Index>& stretch_starts) {
  const Eigen::Index N = y.size();
  const Eigen::Index m = static_cast<Eigen::Index>(orders_.nb.size());
  if (u.cols() != m)
    throw InputError("u must have one column per input (" + std::to_string(m) + "), got " +
                     std::to_string(u.cols()));
  if (u.rows() != N)
    throw InputError("u must have as many rows as y has samples (" + std::to_string(N) + "), got " +
                     std::to_string(u.rows()));
  detail::stretch_spans(N, stretch_starts, stretches_);
  equations_.clear();
  Eigen::Index n_eq = 0;
  for (const auto& s : stretches_)
    if (s.size() > t0_) {
      equations_.push_back({s.begin + t0_, s.end});
      n_eq += s.size() - t0_;
    }
  if (stretches_.size() == 1 && N < min_window())
    throw NumericalError("window too short for the ARX orders: " + std::to_string(N) +
                         " samples, need at least " + std::to_string(min_window()) + " (" +
                         std::to_string(p_) +
                         " parameters, first equation at t0 = " + std::to_string(t0_) + ")");
  if (n_eq < 2 * p_)
    throw NumericalError(
        "stretches too short for the ARX orders: " + std::to_string(n_eq) + " equations in " +
        std::to_string(stretches_.size()) + " stretches, need at least " + std::to_string(2 * p_) +
        " (the first equation is t0 = " + std::to_string(t0_) + " rows into each stretch)");
  if (check_signals_) require_informative_window(y, u);

  // Regressor phi(t) = [-y(t-1) .. -y(t-na), u_j(t-d_j) .. u_j(t-d_j-nb_j+1) ...] (eq. 6).
  std::size_t c = 0;
  for (int k = 1; k <= orders_.na; ++k) columns_[c++] = {y.data(), k, -1.0};
  for (Eigen::Index j = 0; j < m; ++j)
    for (int k = 0; k < orders_.nb[j]; ++k)
      columns_[c++] = {u.col(j).data(), orders_.delays[j] + k, 1.0};

  detail::lagged_normal_equations(columns_, y.data(), equations_, G_, h_);
  const auto outcome = solver_.solve(G_, h_, options_.delta, options_.rank_tolerance, out.theta);
  using Status = detail::NormalEquationsSolver::Status;
  if (outcome.status == Status::ZeroColumn) {
    const Eigen::Index k = outcome.zero_column;
    std::string what = "y";
    if (k >= orders_.na) {
      Eigen::Index j = 0, first = orders_.na;
      while (k >= first + orders_.nb[j]) first += orders_.nb[j++];
      what = "u[" + std::to_string(j) + "]";
    }
    throw NumericalError("window not informative: " + what +
                         " is constant (zero after mean removal) over the ARX equations");
  }
  if (outcome.status == Status::Singular)
    throw NumericalError(
        "window not informative: the ARX regressors are collinear (rank-deficient R; "
        "the inputs do not excite the orders na/nb)");

  // Residual sum of squares from the normal equations, no residual pass:
  // |y - Phi theta|^2 = y'y - 2 theta'h + theta'G theta (exact for the ridge solution
  // too). Cancellation costs ~eps y'y: negligible unless the fit is exact.
  double yy = 0.0;
  for (const auto& e : equations_) yy += y.segment(e.begin, e.size()).squaredNorm();
  const double rss = std::max(0.0, yy - 2.0 * out.theta.dot(h_) + out.theta.dot(G_ * out.theta));
  out.equations = n_eq;
  out.noise_variance = rss / static_cast<double>(n_eq - p_);
  out.regularised = outcome.regularised;
  solver_.covariance_factor(out.covariance);
  out.covariance *= out.noise_variance;

  out.a.resize(orders_.na + 1);
  out.a[0] = 1.0;
  out.a.tail(orders_.na) = out.theta.head(orders_.na);
  out.b.resize(static_cast<std::size_t>(m));
  Eigen::Index offset = orders_.na;
  for (Eigen::Index j = 0; j < m; ++j) {
    out.b[j] = out.theta.segment(offset, orders_.nb[j]);
    offset += orders_.nb[j];
  }
}

ArxResult ArxEstimator::estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                                 const Eigen::Ref<const Eigen::MatrixXd>& u,
                                 const std::vector<Eigen::Index>& stretch_starts) {
  ArxResult out;
  estimate(y, u, out, stretch_starts);
  return out;
}

ArxResult arx(const Eigen::Ref<const Eigen::VectorXd>& y,
              const Eigen::Ref<const Eigen::MatrixXd>& u, const ArxOrders& orders,
              const ArxOptions& options, const std::vector<Eigen::Index>& stretch_starts) {
  return ArxEstimator(orders, options).estimate(y, u, stretch_starts);
}

}  // namespace mpmpp
