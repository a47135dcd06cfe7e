#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mpmpp/error.hpp"
#include "mpmpp/prediction.hpp"
#include "mpmpp/residual_analysis.hpp"

using mpmpp::TransferFunction;

namespace {
Eigen::VectorXd vec(std::initializer_list<double> v) {
  Eigen::VectorXd x(static_cast<Eigen::Index>(v.size()));
  Eigen::Index i = 0;
  for (double c : v) x[i++] = c;
  return x;
}
}  // namespace

// For AR(1) noise H = 1/(1 - a q^-1) the k-step prediction error of v is analytic:
// v(t) - a^k v(t-k) (Ljung eq. 3.31 worked out); with G = 0 the output is v itself.
TEST(Prediction, KStepErrorOfAr1NoiseIsAnalytic) {
  const double a = 0.8;
  TransferFunction h(vec({1.0}), vec({1.0, -a}));
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss;
  Eigen::VectorXd y(400);
  for (auto& c : y) c = gauss(rng);
  Eigen::MatrixXd u = Eigen::MatrixXd::Zero(400, 1);
  mpmpp::ModelRow row{std::nullopt};
  for (int k : {1, 2, 5}) {
    Eigen::VectorXd yhat = mpmpp::predict_output(row, h, y, u, k);
    for (int t = k; t < 400; ++t)
      EXPECT_NEAR(y[t] - yhat[t], y[t] - std::pow(a, k) * y[t - k], 1e-12);
  }
  // Horizon 0 is simulation: with no channel the prediction is zero.
  EXPECT_EQ(mpmpp::predict_output(row, h, y, u, 0).norm(), 0.0);
}

TEST(Prediction, OneStepErrorOfTrueModelIsTheInnovation) {
  TransferFunction g(vec({0.1}), vec({1.0, -0.9}), 3), h(vec({1.0, -0.3}), vec({1.0, 0.5}));
  std::mt19937 rng(5);
  std::normal_distribution<double> gauss;
  Eigen::MatrixXd u(500, 1);
  Eigen::VectorXd e(500);
  for (int t = 0; t < 500; ++t) {
    u(t, 0) = gauss(rng);
    e[t] = gauss(rng);
  }
  Eigen::VectorXd y = g.filter(u.col(0)) + h.filter(e);
  Eigen::VectorXd eps = mpmpp::prediction_error({g}, h, y, u);
  EXPECT_LT((eps - e).cwiseAbs().maxCoeff(), 1e-10);
}

TEST(Prediction, RejectsBadShapesAndNonMonicNoise) {
  TransferFunction g(vec({0.1}), vec({1.0, -0.9}), 3);
  Eigen::MatrixXd u = Eigen::MatrixXd::Zero(10, 2);
  Eigen::VectorXd y = Eigen::VectorXd::Zero(10);
  EXPECT_THROW(mpmpp::output_error({g}, y, u), mpmpp::InputError);
  EXPECT_THROW(mpmpp::predictor_weight(TransferFunction(vec({2.0}), vec({1.0})), 1),
               mpmpp::InputError);
  EXPECT_THROW(mpmpp::predictor_weight(TransferFunction(), 0), mpmpp::InputError);
}

TEST(ResidualAnalysis, CrossCorrelationFindsAShift) {
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss;
  Eigen::VectorXd u(2000), e(2000);
  for (auto& c : u) c = gauss(rng);
  e.setZero();
  e.tail(1996) = u.head(1996);  // e(t) = u(t - 4)
  Eigen::VectorXd r = mpmpp::cross_correlation(e, u, 10);
  Eigen::Index best;
  r.maxCoeff(&best);
  EXPECT_EQ(best - 10, 4);
  EXPECT_NEAR(r[14], 1.0, 0.01);
  // White x: the band is z / sqrt(N) whatever y's colour, since r_xx = delta.
  Eigen::VectorXd rxx = Eigen::VectorXd::Zero(21), ryy = Eigen::VectorXd::Constant(21, 0.5);
  rxx[10] = 1.0;
  ryy[10] = 1.0;
  EXPECT_NEAR(mpmpp::correlation_bound(rxx, ryy, 2000, 2.58), 2.58 / std::sqrt(2000.0), 1e-12);
}

TEST(ResidualAnalysis, WindowedFitMatchesWholeFitOnOneWindow) {
  Eigen::VectorXd y = vec({1, 2, 3, 4, 5, 6}), yhat = vec({1, 2, 3, 4, 5, 5});
  Eigen::MatrixXd w = mpmpp::windowed_fit(y, yhat, 6, 1);
  ASSERT_EQ(w.rows(), 1);
  EXPECT_NEAR(w(0, 1), mpmpp::fit_percent(y, yhat), 1e-12);
  EXPECT_NEAR(mpmpp::fit_percent(y, yhat), 100.0 * (1.0 - 1.0 / std::sqrt(17.5)), 1e-12);
  EXPECT_EQ(mpmpp::windowed_fit(y, yhat, 3, 2).rows(), 2);
}
