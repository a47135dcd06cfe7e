#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mpmpp/chi_square.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/residual_regression.hpp"
#include "small_loop.hpp"

using namespace mpmpp;

TEST(ChiSquare, MatchesClosedForms) {
  // dof 2: P(X > x) = exp(-x / 2); dof 1: erfc(sqrt(x / 2)); dof 4: (1 + x / 2) exp(-x / 2).
  for (double x : {0.01, 0.5, 1.0, 3.0, 7.5, 20.0, 60.0}) {
    EXPECT_NEAR(chi_square_survival(x, 2), std::exp(-x / 2),
                1e-13 * std::max(1.0, 1 / std::exp(-x / 2)) * std::exp(-x / 2) + 1e-15);
    EXPECT_NEAR(chi_square_survival(x, 1) / std::erfc(std::sqrt(x / 2)), 1.0, 1e-10);
    EXPECT_NEAR(chi_square_survival(x, 4) / ((1 + x / 2) * std::exp(-x / 2)), 1.0, 1e-10);
  }
  EXPECT_EQ(chi_square_survival(0.0, 3), 1.0);
  EXPECT_THROW(chi_square_survival(1.0, 0), InputError);
}

TEST(ResidualRegression, FindsAGainChangeAndNothingWithoutOne) {
  const Model m = test_loops::small_siso_model(3);
  DetectorConfig c = DetectorConfig::siso();
  c.arx_order_a = 3;
  const ResidualRegression r(m, 0, {0}, c);
  ASSERT_EQ(r.block_size(0), 3 + c.laguerre_terms);
  const test_loops::LoopSamples s = test_loops::random_step_samples(m, 4000, 7);
  std::vector<Eigen::VectorXd> beta;
  std::vector<Eigen::MatrixXd> cov;
  ASSERT_TRUE(r.estimate(s.y.col(0), s.u, beta, cov));
  // Right model: the coefficients are noise, chi-square with the block's degrees of freedom.
  const double t0 = beta[0].dot(cov[0].ldlt().solve(beta[0]));
  EXPECT_LT(t0, 30.0);
  // The plant's gain x1.5: the gain direction's coefficient is 0.5, far outside its error.
  const Eigen::VectorXd y = s.y.col(0) + 0.5 * m.process[0][0]->filter(s.u.col(0));
  ASSERT_TRUE(r.estimate(y, s.u, beta, cov));
  EXPECT_NEAR(beta[0][0], 0.5, 6 * std::sqrt(cov[0](0, 0)) + 0.05);
  EXPECT_GT(beta[0].dot(cov[0].ldlt().solve(beta[0])), 200.0);
}

TEST(ResidualRegression, RefusesAWindowTooShortAndAnInputWithoutAChannel) {
  const Model m = test_loops::small_siso_model(3);
  const DetectorConfig c = DetectorConfig::siso();
  EXPECT_THROW(ResidualRegression(m, 0, {1}, c), InputError);
  const ResidualRegression r(m, 0, {0}, c);
  const test_loops::LoopSamples s = test_loops::random_step_samples(m, 60, 3);
  std::vector<Eigen::VectorXd> beta;
  std::vector<Eigen::MatrixXd> cov;
  std::string reason;
  EXPECT_FALSE(r.estimate(s.y.col(0), s.u, beta, cov, &reason));
  EXPECT_NE(reason.find("too short"), std::string::npos);
}
