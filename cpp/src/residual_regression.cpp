#include "mpmpp/residual_regression.hpp"

#include <algorithm>
#include <cmath>

#include "mpmpp/arx_oe.hpp"
#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

// Singular values below this fraction of the largest (regressors scaled to unit RMS) are
// taken as exact collinearity: the same structural directions in every window.
constexpr double kRankTolerance = 1e-8;

// Alternations of A(q) and beta. Two: run to convergence (6 passes) the joint fit trades
// beta against A(q), its conditional covariance understates beta's spread, and the paper SISO
// noise change raised a false MPM alarm in 18 of 40 runs (seeds 0-39, window level 0.05)
// instead of 7.
constexpr int kPasses = 2;

// The slowest pole's magnitude, the time scale of the channel's response, kept inside
// [0.2, 0.99] so the Laguerre filters neither vanish in one sample nor never settle.
double laguerre_pole(const TransferFunction& g) {
  double p = 0.5;
  if (g.den().size() > 1) p = g.poles().cwiseAbs().maxCoeff();
  return std::clamp(p, 0.2, 0.99);
}

// L_k(q) = sqrt(1 - p^2) q^-1 (q^-1 - p)^k / (1 - p q^-1)^(k+1), k = 0..n-1: orthonormal
// impulse responses on one time scale.
std::vector<TransferFunction> laguerre_filters(double p, int n) {
  const Eigen::VectorXd pole = Eigen::Vector2d(1.0, -p);
  const TransferFunction all_pass(Eigen::Vector2d(-p, 1.0), pole);
  TransferFunction l(Eigen::VectorXd::Constant(1, std::sqrt(1.0 - p * p)), pole, 1);
  std::vector<TransferFunction> filters;
  for (int k = 0; k < n; ++k) {
    filters.push_back(l);
    l = l.series(all_pass);
  }
  return filters;
}

// Least squares b = argmin ||z - Z b|| by a truncated SVD of the column-scaled Z, with the
// covariance sigma^2 (Z'Z)^+ on the same subspace. False when Z has no usable column.
bool truncated_least_squares(const Eigen::MatrixXd& Z, const Eigen::VectorXd& z, Eigen::VectorXd& b,
                             Eigen::MatrixXd* covariance) {
  const Eigen::Index n = Z.rows(), p = Z.cols();
  Eigen::VectorXd scale =
      (Z.colwise().squaredNorm().transpose() / static_cast<double>(n)).cwiseSqrt();
  for (Eigen::Index k = 0; k < p; ++k)
    if (!(scale[k] > 0)) scale[k] = 1.0;
  const Eigen::MatrixXd Zs = Z * scale.cwiseInverse().asDiagonal();
  const Eigen::BDCSVD<Eigen::MatrixXd> svd(Zs, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& s = svd.singularValues();
  if (s.size() == 0 || !(s[0] > 0)) return false;
  Eigen::Index rank = 0;
  while (rank < s.size() && s[rank] > kRankTolerance * s[0]) ++rank;
  const Eigen::MatrixXd V = svd.matrixV().leftCols(rank);
  const Eigen::VectorXd inv_s = s.head(rank).cwiseInverse();
  const Eigen::VectorXd bs =
      V * (inv_s.asDiagonal() * (svd.matrixU().leftCols(rank).transpose() * z));
  b = scale.cwiseInverse().asDiagonal() * bs;
  if (covariance) {
    if (n <= rank) return false;
    const double sigma2 = (z - Zs * bs).squaredNorm() / static_cast<double>(n - rank);
    const Eigen::MatrixXd Vs = V * inv_s.asDiagonal();
    *covariance = scale.cwiseInverse().asDiagonal() * (sigma2 * Vs * Vs.transpose()) *
                  scale.cwiseInverse().asDiagonal();
  }
  return true;
}

// x(t) - sum_k a_k x(t - k) for t = na .. n-1 (A(q) = 1 - a_1 q^-1 - ... applied to a block).
Eigen::MatrixXd whiten(const Eigen::MatrixXd& x, const Eigen::VectorXd& a) {
  const Eigen::Index na = a.size(), m = x.rows() - na;
  Eigen::MatrixXd w = x.bottomRows(m);
  for (Eigen::Index k = 1; k <= na; ++k) w -= a[k - 1] * x.middleRows(na - k, m);
  return w;
}

}  // namespace

ResidualRegression::ResidualRegression(const Model& nominal, int output, std::vector<int> inputs,
                                       const DetectorConfig& config)
    : ar_order_(config.residual_ar_order > 0 ? config.residual_ar_order : config.arx_order_a),
      settle_(0) {
  for (int j : inputs) {
    if (j < 0 || j >= nominal.num_inputs() || !nominal.has_channel(output, j))
      throw InputError("residual regression: output '" + nominal.outputs[output] +
                       "' has no channel from input " + std::to_string(j));
    const TransferFunction& g = *nominal.process[output][j];
    nominal_.push_back(g);
    // Gain, then two dead-time shifts (one sample either way; d + 2 when d - 1 would be lag 0).
    const int other = g.delay() >= 2 ? g.delay() - 1 : g.delay() + 2;
    std::vector<TransferFunction> dirs{g, TransferFunction(g.num(), g.den(), g.delay() + 1),
                                       TransferFunction(g.num(), g.den(), other)};
    const double p = laguerre_pole(g);
    for (auto& l : laguerre_filters(p, config.laguerre_terms)) dirs.push_back(std::move(l));
    directions_.push_back(std::move(dirs));
    const int laguerre_settle =
        static_cast<int>(std::ceil((config.laguerre_terms + 1) * std::log(0.01) / std::log(p)));
    settle_ = std::max({settle_, fir_length_to_one_percent(g) + 1, laguerre_settle});
  }
}

bool ResidualRegression::estimate(const Eigen::Ref<const Eigen::VectorXd>& y,
                                  const Eigen::Ref<const Eigen::MatrixXd>& u,
                                  std::vector<Eigen::VectorXd>& beta,
                                  std::vector<Eigen::MatrixXd>& covariance, std::string* reason,
                                  Eigen::VectorXd* ar, Eigen::MatrixXd* ar_covariance) const {
  const Eigen::Index n = y.size();
  const int ne = static_cast<int>(nominal_.size());
  if (u.rows() != n || u.cols() != ne)
    throw InputError("residual regression: u must be " + std::to_string(n) + " x " +
                     std::to_string(ne));
  Eigen::Index columns = 0;
  for (const auto& d : directions_) columns += static_cast<Eigen::Index>(d.size());
  // Filters start from rest: the first settle samples only warm them up (at most a third).
  const Eigen::Index skip = std::min<Eigen::Index>(settle_, n / 3), m = n - skip;
  if (m - ar_order_ < 4 * (columns + ar_order_ + 2)) {
    if (reason) *reason = "window too short for the residual regression";
    return false;
  }
  // Deviations from the window's means: the filters start from rest at the operating point,
  // so their start-up transient is that of the deviations only (and settles within skip).
  Eigen::VectorXd v = y.array() - y.mean();
  Eigen::MatrixXd X(n, columns);
  Eigen::Index c = 0;
  for (int e = 0; e < ne; ++e) {
    const Eigen::VectorXd ue = u.col(e).array() - u.col(e).mean();
    v -= nominal_[e].filter(ue);
    for (const auto& d : directions_[e]) X.col(c++) = d.filter(ue);
  }
  const Eigen::VectorXd vv = v.tail(m);
  const Eigen::MatrixXd XX = X.bottomRows(m);
  const Eigen::Index rows = m - ar_order_;
  // A level and a ramp in both steps: drifting disturbances are not a process change.
  Eigen::MatrixXd trend(rows, 2);
  trend.col(0).setOnes();
  trend.col(1) = Eigen::VectorXd::LinSpaced(rows, 0.0, 1.0);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(columns), coef;
  Eigen::MatrixXd cov;
  for (int pass = 0; pass < kPasses; ++pass) {
    // A(q) from what the current beta leaves of v.
    const Eigen::VectorXd r = vv - XX * b;
    Eigen::MatrixXd R(rows, ar_order_ + 2);
    for (int k = 1; k <= ar_order_; ++k) R.col(k - 1) = r.segment(ar_order_ - k, rows);
    R.rightCols(2) = trend;
    Eigen::MatrixXd acov;
    const bool last = pass == kPasses - 1;
    if (!truncated_least_squares(R, r.tail(rows), coef, last && ar_covariance ? &acov : nullptr)) {
      if (reason) *reason = "the output error does not vary in the window";
      return false;
    }
    const Eigen::VectorXd a = coef.head(ar_order_);
    if (last && ar) *ar = -a;  // A(q) v = v - sum a_k v(t-k): ar_k = -a_k, the ARX step's signs
    if (last && ar_covariance) *ar_covariance = acov.topLeftCorner(ar_order_, ar_order_);
    Eigen::MatrixXd Z(rows, columns + 2);
    Z.leftCols(columns) = whiten(XX, a);
    Z.rightCols(2) = trend;
    if (!truncated_least_squares(Z, whiten(vv, a), coef, pass == kPasses - 1 ? &cov : nullptr)) {
      if (reason) *reason = "the inputs do not vary in the window";
      return false;
    }
    b = coef.head(columns);
  }
  if (!cov.allFinite()) {
    if (reason) *reason = "the residual regression is singular in the window";
    return false;
  }
  beta.resize(ne);
  covariance.resize(ne);
  c = 0;
  for (int e = 0; e < ne; ++e) {
    const Eigen::Index p = static_cast<Eigen::Index>(directions_[e].size());
    beta[e] = b.segment(c, p);
    covariance[e] = cov.block(c, c, p, p);
    c += p;
  }
  return true;
}

}  // namespace mpmpp
