#include "mpmpp/detail/lagged_regression.hpp"

#include <cmath>

namespace mpmpp::detail {

namespace {
using ConstSegment = Eigen::Map<const Eigen::VectorXd>;

ConstSegment column_segment(const LaggedColumn& c, Eigen::Index t0, Eigen::Index n) {
  return ConstSegment(c.signal + (t0 - c.lag), n);
}
}  // namespace

void lagged_normal_equations(const std::vector<LaggedColumn>& columns, const double* target,
                             Eigen::Index t0, Eigen::Index n, Eigen::MatrixXd& G,
                             Eigen::VectorXd& h) {
  const Eigen::Index p = static_cast<Eigen::Index>(columns.size());
  G.resize(p, p);
  h.resize(p);
  const ConstSegment y(target + t0, n);
  for (Eigen::Index i = 0; i < p; ++i) {
    const ConstSegment xi = column_segment(columns[i], t0, n);
    h[i] = columns[i].sign * xi.dot(y);
    for (Eigen::Index j = 0; j <= i; ++j) {
      const double s = columns[i].sign * columns[j].sign;
      G(i, j) = G(j, i) = s * xi.dot(column_segment(columns[j], t0, n));
    }
  }
}

void lagged_residual(const std::vector<LaggedColumn>& columns, const double* target,
                     Eigen::Index t0, Eigen::Index n, const Eigen::VectorXd& theta,
                     Eigen::VectorXd& residual) {
  residual = ConstSegment(target + t0, n);
  for (std::size_t k = 0; k < columns.size(); ++k)
    residual -= (columns[k].sign * theta[static_cast<Eigen::Index>(k)]) *
                column_segment(columns[k], t0, n);
}

NormalEquationsSolver::Outcome NormalEquationsSolver::solve(const Eigen::MatrixXd& G,
                                                            const Eigen::VectorXd& h,
                                                            double delta,
                                                            double rank_tolerance,
                                                            Eigen::VectorXd& theta) {
  Outcome out;
  const Eigen::Index p = G.rows();
  scale_.resize(p);
  for (Eigen::Index k = 0; k < p; ++k) {
    // A regressor with (numerically) no energy: a constant input after mean removal.
    if (!(G(k, k) > 0.0)) {
      out.status = Status::ZeroColumn;
      out.zero_column = k;
      return out;
    }
    scale_[k] = 1.0 / std::sqrt(G(k, k));
  }
  scaled_ = scale_.asDiagonal() * G * scale_.asDiagonal();
  eig_.compute(scaled_, Eigen::ComputeEigenvectors);
  const Eigen::VectorXd& lambda = eig_.eigenvalues();  // ascending
  out.min_scaled_eigenvalue = lambda[0];
  if (!(lambda[0] > rank_tolerance * lambda[p - 1])) {
    out.status = Status::Singular;
    return out;
  }
  // Section 3.1: ||Rs^-1||_2 >= 2/delta  <=>  lambda_min(Rs) <= delta/2.
  out.regularised = delta > 0.0 && lambda[0] <= 0.5 * delta;
  shift_ = out.regularised ? 0.5 * delta : 0.0;
  const Eigen::MatrixXd& V = eig_.eigenvectors();
  work_.noalias() = V.transpose() * scale_.cwiseProduct(h);
  work_.array() /= lambda.array() + shift_;
  theta.noalias() = V * work_;
  theta.array() *= scale_.array();
  return out;
}

void NormalEquationsSolver::covariance_factor(Eigen::MatrixXd& C) const {
  // theta = S (Rs + cI)^-1 S h and cov(h) = sigma^2 G give
  // cov(theta) = sigma^2 S V diag(lambda / (lambda + c)^2) V^T S.
  const Eigen::MatrixXd& V = eig_.eigenvectors();
  const Eigen::ArrayXd lambda = eig_.eigenvalues().array();
  const Eigen::VectorXd w = lambda / (lambda + shift_).square();
  C.noalias() = V * w.asDiagonal() * V.transpose();
  C = scale_.asDiagonal() * C * scale_.asDiagonal();
}

}  // namespace mpmpp::detail
