#include <gtest/gtest.h>

#include <cmath>

#include "mpmpp/error.hpp"
#include "mpmpp/valve.hpp"

using mpmpp::Valve;
using mpmpp::ValveKind;

namespace {
Eigen::VectorXd sine(int n, double amplitude, double period) {
  Eigen::VectorXd x(n);
  for (int k = 0; k < n; ++k) x[k] = amplitude * std::sin(2.0 * M_PI * k / period);
  return x;
}
}  // namespace

// Classic hysteresis test: a slow sine of amplitude A through a stick-slip valve peaks at
// A - (S - J)/2 and every slip is a jump of J (analytic, Choudhury et al. 2005 Fig. 5).
TEST(Valve, StickSlipSineHasAnalyticPeakAndJump) {
  const double A = 10.0, S = 4.0, J = 1.5;
  Valve v(ValveKind::StickSlip, S, J);
  Eigen::VectorXd y = v.apply(sine(4000, A, 1000.0));
  EXPECT_NEAR(y.tail(2000).maxCoeff(), A - (S - J) / 2.0, 0.01);
  EXPECT_NEAR(y.tail(2000).minCoeff(), -A + (S - J) / 2.0, 0.01);
  double largest_step = 0.0;
  for (int k = 2001; k < 4000; ++k) largest_step = std::max(largest_step, std::abs(y[k] - y[k - 1]));
  EXPECT_NEAR(largest_step, J, 0.07);
}

// He et al.: once moving the valve lags the OP by fd, so a slow sine peaks within J of A - fd
// (the per-sample OP change is below fs - fd = J, so it moves in slips of about J).
TEST(Valve, HeModelPeakLagsByDynamicFriction) {
  const double A = 10.0, fs = 2.75, fd = 1.25;
  Valve h(ValveKind::He, fs, fd);
  Eigen::VectorXd y = h.apply(sine(3000, A, 1000.0));
  const double peak = y.tail(1500).maxCoeff();
  EXPECT_LE(peak, A - fd + 1e-12);
  EXPECT_GE(peak, A - fd - (fs - fd));
  // a fast OP (change per sample > fs - fd) makes it follow the OP at offset fd
  Valve fast(ValveKind::He, fs, fd);
  Eigen::VectorXd ramp = Eigen::VectorXd::LinSpaced(50, 0.0, 200.0);
  Eigen::VectorXd yr = fast.apply(ramp);
  EXPECT_NEAR(yr[49], 200.0 - fd, 1e-12);
}

TEST(Valve, StaticNonlinearities) {
  Valve dz(ValveKind::Deadband, 1.0, 5.0), sat(ValveKind::Saturation, -2.0, 3.0);
  EXPECT_DOUBLE_EQ(dz.step(5.5), 5.0);
  EXPECT_DOUBLE_EQ(dz.step(8.0), 7.0);
  EXPECT_DOUBLE_EQ(dz.step(2.0), 3.0);
  EXPECT_DOUBLE_EQ(sat.step(-9.0), -2.0);
  EXPECT_DOUBLE_EQ(sat.step(1.0), 1.0);
  EXPECT_DOUBLE_EQ(sat.step(4.0), 3.0);
}

TEST(Valve, RejectsInconsistentParameters) {
  EXPECT_THROW(Valve(ValveKind::StickSlip, 1.0, 2.0), mpmpp::InputError);
  EXPECT_THROW(Valve(ValveKind::Saturation, 2.0, 1.0), mpmpp::InputError);
  Valve v(ValveKind::Linear, 0.0, 0.0);
  EXPECT_THROW(v.step(NAN), mpmpp::InputError);
}
