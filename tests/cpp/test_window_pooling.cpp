#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "mpmpp/error.hpp"
#include "mpmpp/window_pooling.hpp"

using mpmpp::pool_estimates;

TEST(WindowPooling, OneWindowIsItself) {
  const Eigen::Vector2d x(1.0, -2.0);
  Eigen::Matrix2d c;
  c << 2.0, 0.3, 0.3, 1.0;
  const auto p = pool_estimates({x}, {c});
  EXPECT_EQ(p.mean, Eigen::VectorXd(x));
  EXPECT_EQ(p.covariance, Eigen::MatrixXd(c));
}

TEST(WindowPooling, IndependentCoefficientsAreInverseVarianceWeighted) {
  // Analytic: per coefficient, mean (x1/v1 + x2/v2) / (1/v1 + 1/v2), variance 1 / (1/v1 + 1/v2).
  const Eigen::Vector2d x1(1.0, 10.0), x2(4.0, 0.0);
  const Eigen::Vector2d v1(1.0, 1e-4), v2(2.0, 4e-4);
  const auto p = pool_estimates(
      {x1, x2}, {Eigen::MatrixXd(v1.asDiagonal()), Eigen::MatrixXd(v2.asDiagonal())});
  for (int k = 0; k < 2; ++k) {
    const double w1 = 1.0 / v1[k], w2 = 1.0 / v2[k];
    EXPECT_NEAR(p.mean[k], (w1 * x1[k] + w2 * x2[k]) / (w1 + w2), 1e-12 * (1 + std::abs(x1[k])));
    EXPECT_NEAR(p.covariance(k, k), 1.0 / (w1 + w2), 1e-12 * v1[k]);
  }
  EXPECT_NEAR(p.covariance(0, 1), 0.0, 1e-15);
}

TEST(WindowPooling, CorrelatedCoefficientsMatchTheInverseFormula) {
  Eigen::Matrix3d a, b;
  a << 2.0, 0.9, 0.1, 0.9, 1.0, 0.2, 0.1, 0.2, 0.5;
  b << 1.0, -0.4, 0.0, -0.4, 3.0, 0.6, 0.0, 0.6, 0.8;
  const Eigen::Vector3d x1(0.5, -1.0, 2.0), x2(1.5, 0.0, -1.0);
  const Eigen::Matrix3d c = (a.inverse() + b.inverse()).inverse();
  const Eigen::Vector3d m = c * (a.inverse() * x1 + b.inverse() * x2);
  const auto p = pool_estimates({x1, x2}, {a, b});
  EXPECT_LT((p.mean - m).norm(), 1e-12);
  EXPECT_LT((p.covariance - c).norm(), 1e-12);
}

TEST(WindowPooling, ADirectionOneWindowDoesNotResolveComesFromTheOther) {
  // The residual regression's covariance is sigma^2 (Z'Z)^+ on the directions its window
  // resolves: a zero eigenvalue means "no information", not "known exactly".
  const Eigen::Vector2d x1(1.0, 2.0), x2(3.0, 100.0);
  const Eigen::Matrix2d c1 = Eigen::Matrix2d::Identity();
  Eigen::Matrix2d c2 = Eigen::Matrix2d::Zero();
  c2(0, 0) = 1.0;
  const auto p = pool_estimates({x1, x2}, {c1, c2});
  EXPECT_NEAR(p.mean[0], 2.0, 1e-12);
  EXPECT_NEAR(p.mean[1], 2.0, 1e-12);
  EXPECT_NEAR(p.covariance(0, 0), 0.5, 1e-12);
  EXPECT_NEAR(p.covariance(1, 1), 1.0, 1e-12);
}

TEST(WindowPooling, MismatchedInputsAreErrors) {
  const Eigen::Vector2d x(1.0, 2.0);
  const Eigen::Matrix2d c = Eigen::Matrix2d::Identity();
  EXPECT_THROW(pool_estimates({}, {}), mpmpp::InputError);
  EXPECT_THROW(pool_estimates({x, x}, {c}), mpmpp::InputError);
  EXPECT_THROW(pool_estimates({x, Eigen::Vector3d::Zero()}, {c, c}), mpmpp::InputError);
}
