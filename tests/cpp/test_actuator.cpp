#include <gtest/gtest.h>

#include <cmath>

#include "mpmpp/actuator.hpp"
#include "mpmpp/error.hpp"

namespace {

Eigen::VectorXd sine(int n, double amplitude, double period) {
  Eigen::VectorXd x(n);
  for (int k = 0; k < n; ++k) x[k] = amplitude * std::sin(2.0 * M_PI * k / period);
  return x;
}

mpmpp::ActuatorNonlinearity stiction(double s, double j,
                                     mpmpp::StictionLaw law = mpmpp::StictionLaw::Choudhury) {
  mpmpp::ActuatorNonlinearity nl;
  nl.stiction_law = law;
  nl.stiction_s = s;
  nl.stiction_j = j;
  return nl;
}

// From rest, a rising ramp leaves the valve stuck until the command has travelled more than S;
// it then jumps to command - (S - J)/2 and follows (Choudhury et al. 2005).
TEST(Actuator, StictionBreaksFreeAfterS) {
  Eigen::VectorXd ramp = Eigen::VectorXd::LinSpaced(40, 0.1, 4.0);
  const Eigen::VectorXd y = mpmpp::actuator_positions(ramp, stiction(2.0, 0.5), 0.0);
  for (int t = 0; t < 40; ++t) {
    if (ramp[t] <= 2.0 + 1e-12)
      EXPECT_EQ(y[t], 0.0) << t;
    else
      EXPECT_NEAR(y[t], ramp[t] - 0.75, 1e-12) << t;
  }
}

// Classic hysteresis test: a slow sine of amplitude A through a Choudhury valve peaks at
// A - (S - J)/2 and every slip is a jump of J (analytic, Choudhury et al. 2005 Fig. 5).
TEST(Actuator, ChoudhurySineHasAnalyticPeakAndJump) {
  const double A = 10.0, S = 4.0, J = 1.5;
  const Eigen::VectorXd y = mpmpp::actuator_positions(sine(4000, A, 1000.0), stiction(S, J), 0.0);
  EXPECT_NEAR(y.tail(2000).maxCoeff(), A - (S - J) / 2.0, 0.01);
  EXPECT_NEAR(y.tail(2000).minCoeff(), -A + (S - J) / 2.0, 0.01);
  double largest_step = 0.0;
  for (int k = 2001; k < 4000; ++k)
    largest_step = std::max(largest_step, std::abs(y[k] - y[k - 1]));
  EXPECT_NEAR(largest_step, J, 0.07);
}

// He et al.: once moving the valve lags the command by fd = (S - J)/2, so a slow sine peaks
// within J = fs - fd of A - fd; a command faster than J per sample keeps it moving at offset fd.
TEST(Actuator, HeLawLagsByDynamicFriction) {
  const double A = 10.0, fs = 2.75, fd = 1.25;
  const auto he = stiction(fs + fd, fs - fd, mpmpp::StictionLaw::He);
  const Eigen::VectorXd y = mpmpp::actuator_positions(sine(3000, A, 1000.0), he, 0.0);
  const double peak = y.tail(1500).maxCoeff();
  EXPECT_LE(peak, A - fd + 1e-12);
  EXPECT_GE(peak, A - fd - (fs - fd));
  const Eigen::VectorXd ramp = Eigen::VectorXd::LinSpaced(50, 0.0, 200.0);
  EXPECT_NEAR(mpmpp::actuator_positions(ramp, he, 0.0)[49], 200.0 - fd, 1e-12);
}

TEST(Actuator, WithoutNonlinearityItIsTheIdentity) {
  const Eigen::VectorXd x = Eigen::VectorXd::Random(200);
  EXPECT_EQ(mpmpp::actuator_positions(x, {}, 0.0), x);
  EXPECT_EQ(mpmpp::actuator_positions(x, stiction(0.0, 0.0, mpmpp::StictionLaw::He), 0.0), x);
}

// Stepping sample by sample is the whole-sequence map.
TEST(Actuator, SteppingMatchesTheSequence) {
  const Eigen::VectorXd x = 5.0 * Eigen::VectorXd::Random(300);
  auto nl = stiction(1.5, 0.5, mpmpp::StictionLaw::He);
  nl.backlash = 0.4;
  nl.max = 3.0;
  const Eigen::VectorXd y = mpmpp::actuator_positions(x, nl, 1.0);
  mpmpp::Actuator a(nl, 1.0);
  for (int t = 0; t < 300; ++t) EXPECT_EQ(a.move(x[t]), y[t]) << t;
}

TEST(Actuator, RejectsBadParametersAndCommands) {
  EXPECT_THROW(mpmpp::actuator_positions(Eigen::VectorXd::Zero(3), stiction(1.0, 2.0), 0.0),
               mpmpp::InputError);
  Eigen::VectorXd bad = Eigen::VectorXd::Zero(3);
  bad[1] = NAN;
  EXPECT_THROW(mpmpp::actuator_positions(bad, {}, 0.0), mpmpp::InputError);
}

}  // namespace
