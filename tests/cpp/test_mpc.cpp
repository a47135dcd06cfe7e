#include <gtest/gtest.h>

#include "mpmpp/error.hpp"
#include "mpmpp/mpc.hpp"

namespace {

using mpmpp::TransferFunction;
using Vec = Eigen::VectorXd;

Vec vec(std::initializer_list<double> v) {
  return Eigen::Map<const Vec>(v.begin(), static_cast<Eigen::Index>(v.size()));
}

// Table 4's MIMO model: horizon 20 with a 23-sample delay on G22.
mpmpp::Model mimo() {
  mpmpp::Model m;
  m.sample_time_s = 5.0;
  m.inputs = {"stock_flow", "steam_4", "steam_3"};
  m.outputs = {"press_dry_weight", "press_moisture", "reel_moisture"};
  m.process.assign(3, std::vector<std::optional<TransferFunction>>(3));
  m.process[0][0] = TransferFunction(vec({0.0763}), vec({1.0, -0.0723}), 15);
  m.process[1][0] = TransferFunction(vec({0.0305}), vec({1.0, -0.0130}), 19);
  m.process[1][1] = TransferFunction(vec({-0.0026}), vec({1.0, -0.0183}), 23);
  m.process[2][0] = TransferFunction(vec({0.0239}), vec({1.0, -0.0318}), 9);
  m.process[2][1] = TransferFunction(vec({-0.0056}), vec({1.0, -0.0234}), 7);
  m.process[2][2] = TransferFunction(vec({-0.0101}), vec({1.0, -0.1823}), 19);
  m.noise.assign(3, TransferFunction());
  return m;
}

mpmpp::MpcTuning tuning() {
  mpmpp::MpcTuning t;
  t.prediction_horizon = 20;
  t.control_horizon = 2;
  t.cv_target = vec({174.0, 2.3, 6.2});
  t.move_weight = vec({0.01, 0.01, 0.01});
  t.mv_min = vec({0.0, 0.0, 0.0});
  t.mv_max = vec({250.0, 180.0, 180.0});
  t.mv_max_move = vec({0.2, 1.0, 1.0});
  return t;
}

TEST(Mpc, DynamicMatrixIsTheStepResponseFromEachOutputsSmallestDelay) {
  const mpmpp::Model m = mimo();
  mpmpp::Mpc mpc(m, tuning(), vec({165.0, 115.0, 35.0}));
  EXPECT_EQ(mpc.prediction_start(), (Eigen::VectorXi(3) << 15, 19, 7).finished());
  const Eigen::MatrixXd& theta = mpc.dynamic_matrix();
  ASSERT_EQ(theta.rows(), 60);
  ASSERT_EQ(theta.cols(), 6);
  const Vec s22 = m.process[1][1]->step(60);
  for (int k = 0; k < 20; ++k)
    for (int mv = 0; mv < 2; ++mv) {
      EXPECT_DOUBLE_EQ(theta(20 + k, mv * 3 + 1), s22[19 + k - mv]);  // G22 seen from sample 23 on
      EXPECT_EQ(theta(k, mv * 3 + 2), 0.0);                           // G13 absent
    }
}

TEST(Mpc, AtTargetWithoutDisturbanceItDoesNotMove) {
  mpmpp::Mpc mpc(mimo(), tuning(), vec({165.0, 115.0, 35.0}));
  for (int t = 0; t < 30; ++t)
    EXPECT_EQ(mpc.step(vec({174.0, 2.3, 6.2})), vec({165.0, 115.0, 35.0}));
}

TEST(Mpc, MovesStayWithinHardLimits) {
  mpmpp::Mpc mpc(mimo(), tuning(), vec({165.0, 115.0, 35.0}));
  Vec prev = mpc.u();
  for (int t = 0; t < 50; ++t) {
    const Vec u = mpc.step(vec({170.0, 2.0, 7.0}));  // far from target: the move limits bind
    EXPECT_LE(((u - prev).array().abs() - tuning().mv_max_move.array()).maxCoeff(), 1e-9);
    prev = u;
  }
  EXPECT_NEAR(std::abs(mpc.u()[0] - 165.0), 50 * 0.2,
              1e-6);  // stock flow moved at its limit every sample
}

TEST(Mpc, BadTuningThrowsInputError) {
  auto t = tuning();
  t.move_weight = vec({0.01, 0.0, 0.01});
  EXPECT_THROW(mpmpp::Mpc(mimo(), t, vec({165.0, 115.0, 35.0})), mpmpp::InputError);
  EXPECT_THROW(mpmpp::Mpc(mimo(), tuning(), vec({300.0, 115.0, 35.0})), mpmpp::InputError);
  t = tuning();
  t.cv_target = vec({1.0});
  EXPECT_THROW(mpmpp::Mpc(mimo(), t, vec({165.0, 115.0, 35.0})), mpmpp::InputError);
}

}  // namespace
