#include "mpmpp/window_pooling.hpp"

#include <cmath>
#include <string>

#include "mpmpp/detector.hpp"
#include "mpmpp/error.hpp"

namespace mpmpp {

namespace {

// Pseudo-inverse of a symmetric positive semi-definite matrix, eigenvalues below
// ChannelScorer::kWaldRankTolerance times the largest dropped.
Eigen::MatrixXd symmetric_pinv(const Eigen::MatrixXd& m) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(m);
  if (eig.info() != Eigen::Success) throw InputError("window pooling: eigen-decomposition failed");
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  const double cut = ChannelScorer::kWaldRankTolerance * lambda.maxCoeff();
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(lambda.size());
  for (Eigen::Index k = 0; k < lambda.size(); ++k)
    if (lambda[k] > cut) inv[k] = 1.0 / lambda[k];
  return eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace

PooledEstimate pool_estimates(const std::vector<Eigen::VectorXd>& estimates,
                              const std::vector<Eigen::MatrixXd>& covariances) {
  if (estimates.empty() || estimates.size() != covariances.size())
    throw InputError("window pooling: need one covariance per estimate, at least one estimate");
  const Eigen::Index d = estimates[0].size();
  for (size_t i = 0; i < estimates.size(); ++i)
    if (estimates[i].size() != d || covariances[i].rows() != d || covariances[i].cols() != d)
      throw InputError("window pooling: estimate " + std::to_string(i) + " is not of size " +
                       std::to_string(d));
  if (estimates.size() == 1) return {estimates[0], covariances[0]};
  // Correlation form: coefficient k scaled by the root of its mean variance over the windows.
  Eigen::VectorXd variance = Eigen::VectorXd::Zero(d);
  for (const auto& c : covariances) variance += c.diagonal();
  Eigen::VectorXd scale(d), inv_scale(d);
  for (Eigen::Index k = 0; k < d; ++k) {
    scale[k] =
        variance[k] > 0 ? std::sqrt(variance[k] / static_cast<double>(covariances.size())) : 0.0;
    inv_scale[k] = scale[k] > 0 ? 1.0 / scale[k] : 0.0;
  }
  Eigen::MatrixXd precision = Eigen::MatrixXd::Zero(d, d);
  Eigen::VectorXd weighted = Eigen::VectorXd::Zero(d);
  for (size_t i = 0; i < estimates.size(); ++i) {
    const Eigen::MatrixXd p =
        symmetric_pinv(inv_scale.asDiagonal() * covariances[i] * inv_scale.asDiagonal());
    precision += p;
    weighted += p * inv_scale.cwiseProduct(estimates[i]);
  }
  const Eigen::MatrixXd pooled = symmetric_pinv(precision);
  return {scale.cwiseProduct(pooled * weighted), scale.asDiagonal() * pooled * scale.asDiagonal()};
}

}  // namespace mpmpp
