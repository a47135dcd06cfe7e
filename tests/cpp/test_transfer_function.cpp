#include <gtest/gtest.h>

#include <cmath>

#include "mpmpp/error.hpp"
#include "mpmpp/transfer_function.hpp"

using mpmpp::TransferFunction;

TEST(TransferFunction, FirstOrderStepApproachesGain) {
  Eigen::VectorXd num(1), den(2);
  num << 0.1003;
  den << 1.0, -0.9048;
  TransferFunction g(num, den, 17);
  Eigen::VectorXd s = g.step(2000);
  EXPECT_EQ(s.head(17).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_NEAR(s[1999], 0.1003 / (1 - 0.9048), 1e-9);
  EXPECT_NEAR(g.dc_gain(), 0.1003 / (1 - 0.9048), 1e-15);
  EXPECT_TRUE(g.is_stable());
}

TEST(TransferFunction, DenominatorIsNormalised) {
  Eigen::VectorXd num(1), den(2);
  num << 2.0;
  den << 2.0, -1.0;
  TransferFunction g(num, den);
  EXPECT_DOUBLE_EQ(g.den()[0], 1.0);
  EXPECT_DOUBLE_EQ(g.num()[0], 1.0);
}

TEST(TransferFunction, RejectsZeroLeadingDenominator) {
  Eigen::VectorXd num(1), den(2);
  num << 1.0;
  den << 0.0, 1.0;
  EXPECT_THROW(TransferFunction(num, den), mpmpp::InputError);
}

TEST(TransferFunction, FoptdIntegerDelayMatchesPaperSiso) {
  // Paper Sec. 5.1: G0 = 0.1003 q^-17 / (1 - 0.9048 q^-1) at Ts = 5 s, i.e. T = 50 s.
  const double T = -5.0 / std::log(0.9048);
  const double K = 0.1003 / (1 - 0.9048);
  TransferFunction g = TransferFunction::from_foptd(K, T, 16 * 5.0, 5.0);
  EXPECT_EQ(g.delay(), 17);
  EXPECT_NEAR(g.den()[1], -0.9048, 1e-12);
  EXPECT_NEAR(g.num()[0], 0.1003, 1e-12);
}

TEST(TransferFunction, FoptdFractionalDelayKeepsGain) {
  TransferFunction g = TransferFunction::from_foptd(2.0, 30.0, 12.5, 5.0);
  EXPECT_EQ(g.delay(), 3);
  EXPECT_EQ(g.num().size(), 2);
  EXPECT_NEAR(g.dc_gain(), 2.0, 1e-12);
}

namespace {
Eigen::VectorXd vec(std::initializer_list<double> v) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(v.size()));
  Eigen::Index k = 0;
  for (double x : v) out[k++] = x;
  return out;
}
}  // namespace

TEST(TransferFunction, ParallelOfDifferentDelaysAddsResponses) {
  TransferFunction a(vec({0.5}), vec({1.0, -0.5}), 1), b(vec({2.0, 1.0}), vec({1.0}), 3);
  const Eigen::VectorXd x = Eigen::VectorXd::LinSpaced(20, -1.0, 2.0);
  const Eigen::VectorXd expected = a.filter(x) + b.filter(x);
  EXPECT_LT((a.parallel(b).filter(x) - expected).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_EQ(a.parallel(b).delay(), 1);
}

TEST(TransferFunction, SeriesMultipliesGainsAndAddsDelays) {
  TransferFunction a(vec({0.5}), vec({1.0, -0.5}), 2), b(vec({2.0, 1.0}), vec({1.0, 0.25}), 3);
  const TransferFunction s = a.series(b);
  EXPECT_EQ(s.delay(), 5);
  EXPECT_NEAR(s.dc_gain(), a.dc_gain() * b.dc_gain(), 1e-14);
}

TEST(TransferFunction, StabilityAndMinimumPhase) {
  EXPECT_FALSE(TransferFunction(vec({1.0}), vec({1.0, -1.0})).is_stable());      // integrator
  EXPECT_TRUE(TransferFunction(vec({1.0}), vec({1.0, 0.0, 0.81})).is_stable());  // poles +-0.9i
  EXPECT_FALSE(TransferFunction(vec({1.0, -2.0}), vec({1.0})).is_minimum_phase());
  EXPECT_TRUE(std::isinf(TransferFunction(vec({1.0}), vec({1.0, -1.0})).dc_gain()));
}

TEST(TransferFunction, FoptdPureDelayAndLimits) {
  // T = 0: a pure delay; 2.4 samples of dead time act from the third sample on.
  const TransferFunction g = TransferFunction::from_foptd(3.0, 0.0, 12.0, 5.0);
  EXPECT_EQ(g.delay(), 3);
  EXPECT_DOUBLE_EQ(g.step(4)[3], 3.0);
  EXPECT_THROW(TransferFunction::from_foptd(1.0, 1.0, 1e300, 1.0), mpmpp::InputError);
  EXPECT_THROW(TransferFunction::from_foptd(1.0, -1.0, 0.0, 1.0), mpmpp::InputError);
}

TEST(TransferFunction, ToString) {
  EXPECT_EQ(mpmpp::to_string(TransferFunction(vec({0.063}), vec({1.0, -0.93}), 14)),
            "q^-14 (0.063) / (1 - 0.93 q^-1)");
  EXPECT_EQ(mpmpp::to_string(TransferFunction(vec({0.0}), vec({1.0}))), "(0)");
}
