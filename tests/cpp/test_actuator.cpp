#include "mpmpp/actuator.hpp"

#include <gtest/gtest.h>

#include "mpmpp/error.hpp"

namespace {

// From rest, a rising ramp leaves the valve stuck until the command has travelled more than S;
// it then jumps to command - (S - J)/2 and follows (Choudhury et al. 2005).
TEST(Actuator, StictionBreaksFreeAfterS) {
  mpmpp::ActuatorNonlinearity nl;
  nl.stiction_s = 2.0;
  nl.stiction_j = 0.5;
  Eigen::VectorXd ramp = Eigen::VectorXd::LinSpaced(40, 0.1, 4.0);
  const Eigen::VectorXd y = mpmpp::actuator_positions(ramp, nl, 0.0);
  for (int t = 0; t < 40; ++t) {
    if (ramp[t] <= 2.0 + 1e-12) EXPECT_EQ(y[t], 0.0) << t;
    else EXPECT_NEAR(y[t], ramp[t] - 0.75, 1e-12) << t;
  }
}

TEST(Actuator, WithoutNonlinearityItIsTheIdentity) {
  const Eigen::VectorXd x = Eigen::VectorXd::Random(200);
  EXPECT_EQ(mpmpp::actuator_positions(x, {}, 0.0), x);
}

TEST(Actuator, RejectsJAboveS) {
  mpmpp::ActuatorNonlinearity nl;
  nl.stiction_s = 1.0;
  nl.stiction_j = 2.0;
  EXPECT_THROW(mpmpp::actuator_positions(Eigen::VectorXd::Zero(3), nl, 0.0), mpmpp::InputError);
}

}  // namespace
