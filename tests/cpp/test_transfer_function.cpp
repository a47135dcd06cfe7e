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
