#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mpmpp/error.hpp"
#include "mpmpp/one_class_svm.hpp"
#include "mpmpp/resampling.hpp"

using mpmpp::OneClassSvmOptions;
using mpmpp::RowMatrixXd;

namespace {

RowMatrixXd random_points(int n, int d, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  RowMatrixXd X(n, d);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < d; ++j) X(i, j) = normal(rng) + (i % 3 == 0 ? 2.0 : 0.0);
  return X;
}

Eigen::MatrixXd gaussian_gram(const RowMatrixXd& X, double c) {
  const int n = static_cast<int>(X.rows());
  Eigen::MatrixXd K(n, n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) K(i, j) = std::exp(-(X.row(i) - X.row(j)).squaredNorm() / c);
  return K;
}

}  // namespace

// KKT conditions of the dual (18-19) in libsvm scaling, checked with a Gram matrix built here:
// G = K alpha; G_i <= rho + tol at the upper bound, G_i >= rho - tol at zero, G_i ~ rho between.
TEST(OneClassSvm, SolutionSatisfiesKktConditions) {
  const RowMatrixXd X = random_points(120, 3, 1);
  OneClassSvmOptions o;
  o.nu = 0.3;
  o.kernel_scale = 2.0;
  o.tol = 1e-8;
  const mpmpp::OneClassSvmModel m = mpmpp::fit_one_class_svm(X, o);
  ASSERT_TRUE(m.converged);
  Eigen::VectorXd alpha = Eigen::VectorXd::Zero(120);
  for (int k = 0; k < m.support.size(); ++k) alpha[m.support[k]] = m.dual_coef[k];
  EXPECT_NEAR(alpha.sum(), o.nu * 120, 1e-9);
  EXPECT_GE(alpha.minCoeff(), 0.0);
  EXPECT_LE(alpha.maxCoeff(), 1.0);
  const Eigen::VectorXd G = gaussian_gram(X, o.kernel_scale) * alpha;
  int n_free = 0;
  for (int i = 0; i < 120; ++i) {
    if (alpha[i] >= 1.0)
      EXPECT_LE(G[i], m.rho + 1e-6);
    else if (alpha[i] <= 0.0)
      EXPECT_GE(G[i], m.rho - 1e-6);
    else {
      EXPECT_NEAR(G[i], m.rho, 1e-6);
      ++n_free;
    }
  }
  EXPECT_GT(n_free, 0);
  EXPECT_NEAR(m.objective, 0.5 * alpha.dot(G), 1e-6);
  // decision_function = G - rho at the training points.
  const Eigen::VectorXd f = m.decision_function(X);
  EXPECT_LT((f - (G.array() - m.rho).matrix()).cwiseAbs().maxCoeff(), 1e-6);
}

// The cache only changes the cost: a cache of two columns must give the very same iterates.
TEST(OneClassSvm, CacheSizeAndShrinkingDoNotChangeTheSolution) {
  const RowMatrixXd X = random_points(400, 4, 2);
  OneClassSvmOptions big, tiny, plain;
  big.nu = tiny.nu = plain.nu = 0.2;
  tiny.cache_mb = 1e-6;
  plain.shrinking = false;
  plain.tol = big.tol = tiny.tol = 1e-7;
  const auto a = mpmpp::fit_one_class_svm(X, big);
  const auto b = mpmpp::fit_one_class_svm(X, tiny);
  const auto c = mpmpp::fit_one_class_svm(X, plain);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.rho, b.rho);
  ASSERT_EQ(a.dual_coef.size(), b.dual_coef.size());
  EXPECT_EQ((a.dual_coef - b.dual_coef).cwiseAbs().maxCoeff(), 0.0);
  const Eigen::VectorXd fa = a.decision_function(X), fc = c.decision_function(X);
  EXPECT_LT((fa - fc).cwiseAbs().maxCoeff(), 1e-5);
}

TEST(OneClassSvm, RejectsBadInput) {
  RowMatrixXd X = random_points(10, 2, 3);
  OneClassSvmOptions o;
  o.nu = 0.0;
  EXPECT_THROW(mpmpp::fit_one_class_svm(X, o), mpmpp::InputError);
  o.nu = 0.5;
  o.kernel_scale = -1.0;
  EXPECT_THROW(mpmpp::fit_one_class_svm(X, o), mpmpp::InputError);
  o.kernel_scale = 1.0;
  X(3, 1) = std::nan("");
  EXPECT_THROW(mpmpp::fit_one_class_svm(X, o), mpmpp::InputError);
  EXPECT_THROW(mpmpp::fit_one_class_svm(RowMatrixXd(0, 2), o), mpmpp::InputError);
}

TEST(Resampling, CorrelatedDrawsHaveTheSampleCovariance) {
  RowMatrixXd windows = random_points(8, 3, 5);
  windows.col(1) = -windows.col(0) + 0.1 * windows.col(1);  // strongly anti-correlated pair
  const Eigen::MatrixXd S = mpmpp::coefficient_covariance(windows);
  const RowMatrixXd centred = windows.rowwise() - windows.colwise().mean();
  EXPECT_LT((S - centred.transpose() * centred / 7.0).cwiseAbs().maxCoeff(), 1e-14);
  const RowMatrixXd a = mpmpp::resample(windows, 100000, 2.0, 11, true);
  EXPECT_EQ((a - mpmpp::resample(windows, 100000, 2.0, 11, true)).cwiseAbs().maxCoeff(), 0.0);
  const RowMatrixXd ac = a.rowwise() - a.colwise().mean();
  const Eigen::MatrixXd C = ac.transpose() * ac / 99999.0;
  const Eigen::VectorXd sd = S.diagonal().cwiseSqrt();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      EXPECT_NEAR(C(i, j) / (sd[i] * sd[j]), 4.0 * S(i, j) / (sd[i] * sd[j]), 0.05);
  // Fewer windows than coefficients: a singular covariance is an error, not a silent guess.
  EXPECT_THROW(mpmpp::resample(windows.topRows(3), 10, 1.5, 0, true), mpmpp::InputError);
}

TEST(Resampling, DeterministicPerSeedWithTargetMoments) {
  const RowMatrixXd windows = random_points(6, 5, 4);
  const auto s = mpmpp::coefficient_statistics(windows);
  const RowMatrixXd a = mpmpp::resample(windows, 50000, 1.5, 42);
  const RowMatrixXd b = mpmpp::resample(windows, 50000, 1.5, 42);
  const RowMatrixXd c = mpmpp::resample(windows, 50000, 1.5, 43);
  EXPECT_EQ((a - b).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_GT((a - c).cwiseAbs().maxCoeff(), 0.0);
  const Eigen::VectorXd mean = a.colwise().mean().transpose();
  const Eigen::VectorXd sd =
      ((a.rowwise() - mean.transpose()).colwise().squaredNorm().transpose() / 49999.0).cwiseSqrt();
  for (int i = 0; i < 5; ++i) {
    EXPECT_NEAR(mean[i], s.mean[i], 5 * 1.5 * s.std[i] / std::sqrt(50000.0));
    EXPECT_NEAR(sd[i] / (1.5 * s.std[i]), 1.0, 0.02);
  }
  EXPECT_THROW(mpmpp::resample(windows.topRows(1), 10, 1.5, 0), mpmpp::InputError);
  EXPECT_THROW(mpmpp::resample(windows, 10, -1.0, 0), mpmpp::InputError);
}
