#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mpmpp/arx_oe.hpp"
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
  DetectorConfig two_orders = c;  // one whitening order per output, not two on a 1x1 model
  two_orders.residual_ar_orders = {3, 4};
  EXPECT_THROW(ResidualRegression(m, 0, {0}, two_orders), InputError);
  const ResidualRegression r(m, 0, {0}, c);
  const test_loops::LoopSamples s = test_loops::random_step_samples(m, 60, 3);
  std::vector<Eigen::VectorXd> beta;
  std::vector<Eigen::MatrixXd> cov;
  std::string reason;
  EXPECT_FALSE(r.estimate(s.y.col(0), s.u, beta, cov, &reason));
  EXPECT_NE(reason.find("too short"), std::string::npos);
}

// Pure feedback, no excitation: u(t) = -k y(t), white disturbance. When the plant's dead time
// is two samples longer than the model's, the inputs are a filtered copy of the output error's
// past, so a long whitening polynomial can predict dG u from v's own past and take the change
// into the noise model; one near the disturbance's order cannot (docs/detection.md "The
// whitening order"). With the model right, the short whitening leaves the test at its null.
TEST(ResidualRegression, ALongWhiteningAbsorbsADeadTimeChangeUnderPureFeedback) {
  const Model m = test_loops::small_siso_model(2);
  const TransferFunction& g = *m.process[0][0];
  const double b = g.num()[0], a = -g.den()[1];
  auto wald = [&](int plant_delay, int order) {
    const Eigen::Index n = 1440;  // a 2 h window at 5 s
    std::mt19937_64 rng(11);
    std::normal_distribution<double> e(0.0, 0.05);
    Eigen::VectorXd y(n);
    Eigen::MatrixXd u = Eigen::MatrixXd::Zero(n, 1);
    double x = 0.0;  // the process part of y: b q^-d / (1 - a q^-1) u
    for (Eigen::Index t = 0; t < n; ++t) {
      x = a * x + (t >= plant_delay ? b * u(t - plant_delay, 0) : 0.0);
      y[t] = x + e(rng);
      u(t, 0) = -3.0 * y[t];
    }
    DetectorConfig c = DetectorConfig::siso();
    c.residual_ar_orders = {order};
    const ResidualRegression r(m, 0, {0}, c);
    EXPECT_EQ(r.ar_order(), order);
    std::vector<Eigen::VectorXd> beta;
    std::vector<Eigen::MatrixXd> cov;
    EXPECT_TRUE(r.estimate(y, u, beta, cov));
    return beta[0].dot(cov[0].ldlt().solve(beta[0]));
  };
  const double changed_short = wald(g.delay() + 2, 3), changed_long = wald(g.delay() + 2, 18);
  EXPECT_GT(changed_short, 100.0);                // measured 196
  EXPECT_GT(changed_short, 20.0 * changed_long);  // measured 1.3 with AR(18)
  EXPECT_LT(wald(g.delay(), 3), 22.5);            // chi-square(6) at 0.001
}

// A wandering disturbance, (1 - 0.85 q^-1) / (1 - 0.995 q^-1) e, under the same feedback: an AR(3)
// whitening leaves most of its memory in the error, the controller carries it into u, and beta
// reads it as a process change; through the training's moving-average root (residual_ma_roots)
// the same AR(3) whitens it, and a dead-time change still stands out.
TEST(ResidualRegression, AMovingAverageRootWhitensAWanderingDisturbance) {
  const Model m = test_loops::small_siso_model(2);
  const TransferFunction& g = *m.process[0][0];
  const double b = g.num()[0], a = -g.den()[1];
  auto wald = [&](int plant_delay, double root, unsigned seed) {
    const Eigen::Index n = 1440;
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> e(0.0, 0.05);
    Eigen::VectorXd y(n);
    Eigen::MatrixXd u = Eigen::MatrixXd::Zero(n, 1);
    double x = 0.0, w = 0.0, e_last = 0.0;
    for (Eigen::Index t = 0; t < n; ++t) {
      x = a * x + (t >= plant_delay ? b * u(t - plant_delay, 0) : 0.0);
      const double et = e(rng);
      w = 0.995 * w + et - 0.85 * e_last;
      e_last = et;
      y[t] = x + w;
      u(t, 0) = -3.0 * y[t];
    }
    DetectorConfig c = DetectorConfig::siso();
    c.residual_ar_orders = {3};
    c.residual_ma_roots = {root};
    const ResidualRegression r(m, 0, {0}, c);
    std::vector<Eigen::VectorXd> beta;
    std::vector<Eigen::MatrixXd> cov;
    EXPECT_TRUE(r.estimate(y, u, beta, cov));
    return beta[0].dot(cov[0].ldlt().solve(beta[0]));
  };
  double plain = 0.0, rooted = 0.0, changed = 1e300;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    plain += wald(g.delay(), 0.0, seed) / 20;
    rooted += wald(g.delay(), 0.85, seed) / 20;
    changed = std::min(changed, wald(g.delay() + 2, 0.85, seed));
  }
  EXPECT_GT(plain, 50.0);    // measured 327: mean Wald on chi-square(6), the model right
  EXPECT_LT(rooted, 9.0);    // measured 3.2 (chi-square(6) mean 6; conservative under feedback)
  EXPECT_GT(changed, 50.0);  // measured 101, the smallest of the 20 windows
}

// A level: the paper loop's lag before an integrator, u in absolute units far from zero (an OP
// at 40 %), so the integrated input ramps through every window. The window's level and ramp
// carry what the integrator remembers of the time before and the input's offset; the test
// sees the gain change and nothing without it.
TEST(ResidualRegression, AnIntegratingChannelIsTestedLikeAStableOne) {
  Eigen::VectorXd b(1), a(3);
  b << 0.01;
  a << 1.0, -1.9048, 0.9048;  // (1 - 0.9048 q^-1)(1 - q^-1)
  const TransferFunction g(b, a, 3);
  const Model m = make_model("level", 5.0, {"u"}, {"y"}, {{"y", {{"u", g}}}}, {});
  DetectorConfig c = DetectorConfig::siso();
  c.arx_order_a = 3;
  const ResidualRegression r(m, 0, {0}, c);
  // settled once the lag has: as the lag alone would be, not never
  Eigen::VectorXd lag(2);
  lag << 1.0, -0.9048;
  EXPECT_LE(r.settling_samples(), fir_length_to_one_percent(TransferFunction(b, lag, 3)) + 200);
  test_loops::LoopSamples s =
      test_loops::random_step_samples(test_loops::small_siso_model(3), 4000, 11);
  s.u.array() += 40.0;
  std::mt19937_64 rng(5);
  std::normal_distribution<double> e(0.0, 0.05);
  const Eigen::VectorXd noise = Eigen::VectorXd::NullaryExpr(4000, [&] { return e(rng); });
  const Eigen::VectorXd y = g.filter(s.u.col(0)) + noise;
  std::vector<Eigen::VectorXd> beta;
  std::vector<Eigen::MatrixXd> cov;
  ASSERT_TRUE(r.estimate(y, s.u, beta, cov));
  EXPECT_LT(beta[0].dot(cov[0].ldlt().solve(beta[0])), 30.0);
  const Eigen::VectorXd changed = y + 0.5 * g.filter(s.u.col(0));
  ASSERT_TRUE(r.estimate(changed, s.u, beta, cov));
  EXPECT_NEAR(beta[0][0], 0.5, 6 * std::sqrt(cov[0](0, 0)) + 0.05);
  EXPECT_GT(beta[0].dot(cov[0].ldlt().solve(beta[0])), 200.0);
}
