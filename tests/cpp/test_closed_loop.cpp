#include <gtest/gtest.h>

#include "mpmpp/closed_loop.hpp"
#include "mpmpp/detail/incremental_filter.hpp"
#include "mpmpp/error.hpp"

namespace {

using mpmpp::TransferFunction;
using Vec = Eigen::VectorXd;

Vec vec(std::initializer_list<double> v) {
  return Eigen::Map<const Vec>(v.begin(), static_cast<Eigen::Index>(v.size()));
}

// The paper's SISO loop: G0 = 0.1003 q^-17 / (1 - 0.9048 q^-1), Table 2's limits.
mpmpp::ClosedLoopConfig siso(int samples, double sigma) {
  mpmpp::ClosedLoopConfig c;
  TransferFunction g(vec({0.1003}), vec({1.0, -0.9048}), 17), h(vec({1.0, -0.3}), vec({1.0, 0.6}));
  c.model.sample_time_s = 5.0;
  c.model.inputs = {"stock_flow"};
  c.model.outputs = {"dry_weight"};
  c.model.process = {{g}};
  c.model.noise = {h};
  c.tuning.prediction_horizon = 40;
  c.tuning.control_horizon = 4;
  c.tuning.cv_target = vec({23.75});
  c.tuning.mv_target = vec({131.0});
  c.tuning.move_weight = vec({1.0});
  c.tuning.mv_target_weight = vec({1.0});
  c.tuning.mv_min = vec({0.0});
  c.tuning.mv_max = vec({3000.0});
  c.tuning.mv_max_move = vec({0.1667});
  c.plant.process = {{g}};
  c.plant.noise = {h};
  c.plant.sigma = vec({sigma});
  c.num_samples = samples;
  return c;
}

TEST(IncrementalFilter, EqualsBatchFilter) {
  const std::vector<TransferFunction> cases = {
      TransferFunction(vec({0.1003}), vec({1.0, -0.9048}), 17),
      TransferFunction(vec({0.0, 0.2, -0.1}), vec({1.0, -1.2, 0.5}), 3),
      TransferFunction(vec({1.0, 0.3}), vec({1.0, -0.6}), 0),
      TransferFunction(vec({2.5}), vec({1.0}), 4)};
  const Vec x = Vec::Random(300);
  for (const auto& g : cases) {
    mpmpp::detail::IncrementalFilter f(g);
    const Vec batch = g.filter(x);
    for (int t = 0; t < x.size(); ++t) EXPECT_NEAR(f.step(x[t]), batch[t], 1e-12);
  }
}

TEST(IncrementalFilter, AdvancedOneSampleNeedsStrictlyProper) {
  const TransferFunction g(vec({0.0, 0.4}), vec({1.0, -0.5}), 0);
  EXPECT_EQ(mpmpp::detail::advanced_one_sample(g, "g").num().size(), 1);
  EXPECT_THROW(mpmpp::detail::advanced_one_sample(TransferFunction(vec({0.4}), vec({1.0}), 0), "g"),
               mpmpp::InputError);
}

TEST(ClosedLoop, NoNoiseNoMismatchStaysAtTarget) {
  const auto r = mpmpp::simulate_closed_loop(siso(500, 0.0));
  EXPECT_EQ((r.y.array() - 23.75).abs().maxCoeff(), 0.0);
  EXPECT_EQ((r.u.array() - 131.0).abs().maxCoeff(), 0.0);
  EXPECT_EQ(r.failed_solves, 0);
}

TEST(ClosedLoop, GainEventReplaysTheNewChannelOverTheInputHistory) {
  auto c = siso(1500, 0.0);
  c.y_operating = vec({24.0});  // start off target so the inputs move
  const TransferFunction doubled(vec({0.2006}), vec({1.0, -0.9048}), 17);
  mpmpp::Event ev;
  ev.sample = 600;
  ev.kind = mpmpp::EventKind::Process;
  ev.output = 0;
  ev.input = 0;
  ev.model = doubled;
  c.events = {ev};
  const auto r = mpmpp::simulate_closed_loop(c);
  const Vec du = r.u_actual.col(0).array() - 131.0;
  const Vec before = c.plant.process[0][0]->filter(du), after = doubled.filter(du);
  for (int t = 0; t < 1500; ++t)
    EXPECT_NEAR(r.y(t, 0), 24.0 + (t < 600 ? before[t] : after[t]), 1e-10) << t;
  EXPECT_NEAR(r.y(1499, 0), 23.75, 1e-3);  // offset-free after the change
}

// `fresh`: the new channel from rest on the inputs from the event on, the old one's response
// to the earlier inputs fading out (a simulator that swaps the channel's filter).
TEST(ClosedLoop, FreshGainEventStartsTheNewChannelFromRest) {
  auto c = siso(1500, 0.0);
  c.y_operating = vec({24.0});
  const TransferFunction doubled(vec({0.2006}), vec({1.0, -0.9048}), 17);
  mpmpp::Event ev;
  ev.sample = 600;
  ev.kind = mpmpp::EventKind::Process;
  ev.output = ev.input = 0;
  ev.model = doubled;
  ev.fresh = true;
  c.events = {ev};
  const auto r = mpmpp::simulate_closed_loop(c);
  const Vec du = r.u_actual.col(0).array() - 131.0;
  Vec early = du, late = du;  // inputs up to sample 598 / from 599 on (the one-sample advance)
  early.tail(du.size() - 599).setZero();
  late.head(599).setZero();
  const Vec before = c.plant.process[0][0]->filter(du),
            after = c.plant.process[0][0]->filter(early) + doubled.filter(late);
  for (int t = 0; t < 1500; ++t)
    EXPECT_NEAR(r.y(t, 0), 24.0 + (t < 600 ? before[t] : after[t]), 1e-10) << t;
  // The two conventions differ by the channel change's response to the earlier inputs.
  c.events[0].fresh = false;
  const auto replay = mpmpp::simulate_closed_loop(c);
  EXPECT_GT((replay.y.col(0) - r.y.col(0)).cwiseAbs().maxCoeff(), 1e-3);
}

TEST(ClosedLoop, EveryEventKindTakesEffectAtItsSample) {
  auto c = siso(600, 0.05);
  mpmpp::ExtraVariable x;
  x.name = "consistency";
  x.operating_point = 1.1;
  x.sigma = 0.2;
  c.plant.extra = {x};
  c.plant.extra_process = {{std::nullopt}};
  c.plant.actuators = {mpmpp::ActuatorNonlinearity{}};
  auto event = [](int sample, mpmpp::EventKind kind) {
    mpmpp::Event e;
    e.sample = sample;
    e.kind = kind;
    e.output = 0;
    e.input = 0;
    return e;
  };
  auto extra = event(100, mpmpp::EventKind::ExtraProcess);
  extra.model = TransferFunction(vec({0.0, 0.5}), vec({1.0, -0.6}), 2);
  auto noise = event(150, mpmpp::EventKind::Noise);
  noise.model = TransferFunction(vec({1.0, 0.3}), vec({1.0, -0.6}), 0);
  auto sigma = event(200, mpmpp::EventKind::Sigma);
  sigma.value = 0.1;
  auto drift = event(250, mpmpp::EventKind::Drift);
  drift.value = 0.3;
  drift.rate = 0.001;
  auto actuator = event(300, mpmpp::EventKind::Actuator);
  actuator.actuator.deadband = 0.05;
  actuator.actuator.min = 130.95;
  actuator.actuator.max = 131.05;
  auto setpoint = event(350, mpmpp::EventKind::CvTarget);
  setpoint.value = 24.0;
  auto mv_target = event(400, mpmpp::EventKind::MvTarget);
  mv_target.value = 132.0;
  auto removed = event(450, mpmpp::EventKind::Process);  // the plant loses its only channel
  c.events = {removed, mv_target, setpoint, actuator, drift, sigma, noise, extra};  // any order
  const auto r = mpmpp::simulate_closed_loop(c);
  EXPECT_EQ(r.setpoint(349, 0), 23.75);
  EXPECT_EQ(r.setpoint(350, 0), 24.0);
  EXPECT_GE(r.u_actual.col(0).tail(300).minCoeff(), 130.95);
  EXPECT_LE(r.u_actual.col(0).tail(300).maxCoeff(), 131.05);
  EXPECT_GT((r.u_actual.col(0).tail(300) - r.u.col(0).tail(300)).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_NEAR(r.extra.col(0).mean(), 1.1, 0.1);
  EXPECT_EQ(r.failed_solves, 0);
}

TEST(ClosedLoop, SameSeedSameRun) {
  auto c = siso(400, 0.05);
  c.seed = 11;
  const auto a = mpmpp::simulate_closed_loop(c), b = mpmpp::simulate_closed_loop(c);
  EXPECT_TRUE(a.y == b.y && a.u == b.u);
  c.seed = 12;
  EXPECT_FALSE(mpmpp::simulate_closed_loop(c).y == a.y);
}

TEST(ClosedLoop, BadInputThrowsInputError) {
  auto c = siso(100, 0.05);
  mpmpp::Event ev;
  ev.sample = 100;  // == num_samples: outside
  ev.kind = mpmpp::EventKind::Sigma;
  ev.output = 0;
  c.events = {ev};
  EXPECT_THROW(mpmpp::simulate_closed_loop(c), mpmpp::InputError);
  c = siso(100, -1.0);
  EXPECT_THROW(mpmpp::simulate_closed_loop(c), mpmpp::InputError);
  c = siso(100, 0.05);
  c.plant.noise = {TransferFunction(vec({1.0}), vec({1.0, -1.5}), 0)};
  EXPECT_THROW(mpmpp::simulate_closed_loop(c), mpmpp::InputError);
  c = siso(100, 0.05);
  ev.sample = 50;
  ev.value = 0.1;
  ev.fresh = true;  // a switch only a channel event has
  c.events = {ev};
  EXPECT_THROW(mpmpp::simulate_closed_loop(c), mpmpp::InputError);
}

}  // namespace

namespace {

// The paper's SISO loop under a PI controller (SIMC-like: K 0.25, Ti 50 s) with one event.
mpmpp::ClosedLoopConfig pi_siso(int samples, mpmpp::EventKind kind, int sample, double value) {
  auto c = siso(samples, 0.05);
  mpmpp::PidLoop l;
  l.gain = 0.25;
  l.integral_time_s = 50.0;
  l.min = 120.0;
  l.max = 140.0;
  c.pid_loops = {l};
  mpmpp::Event ev;
  ev.sample = sample;
  ev.kind = kind;
  ev.output = ev.input = 0;
  ev.value = value;
  c.events = {ev};
  return c;
}

}  // namespace

TEST(ClosedLoop, PidLoopsReplaceTheMpcAndFollowTheirLaw) {
  const auto c = pi_siso(3000, mpmpp::EventKind::CvTarget, 1000, 24.5);
  const auto res = mpmpp::simulate_closed_loop(c);
  // The recorded commands are the PI law applied to the recorded measurements and setpoints.
  const Eigen::MatrixXd u = mpmpp::pid_outputs(c.pid_loops, 5.0, vec({131.0}), res.y, res.setpoint);
  EXPECT_LT((u - res.u).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LE(res.u.maxCoeff(), 140.0);
  EXPECT_GE(res.u.minCoeff(), 120.0);
  EXPECT_NEAR(res.y.bottomRows(500).mean(), 24.5, 0.05);  // integral action: no offset
  EXPECT_EQ(res.failed_solves, 0);
}

// Given sequences add to y and to the actuator position: without noise, y - y0 - d is the
// truth channel filtered over the recorded positions (TransferFunction::filter as reference).
TEST(ClosedLoop, GivenDisturbanceAndPositionNoiseAdd) {
  auto c = pi_siso(800, mpmpp::EventKind::CvTarget, 300, 24.5);
  c.plant.sigma = vec({0.0});
  c.output_disturbance = 0.3 * Eigen::MatrixXd::Random(800, 1);
  c.position_noise = 0.5 * Eigen::MatrixXd::Random(800, 1);
  const auto res = mpmpp::simulate_closed_loop(c);
  EXPECT_LT((res.u_actual - res.u - c.position_noise).cwiseAbs().maxCoeff(), 1e-12);
  const Vec ua_dev = res.u_actual.col(0).array() - 131.0;
  const Vec y = c.plant.process[0][0]->filter(ua_dev).array() + 23.75;
  EXPECT_LT((res.y.col(0) - c.output_disturbance.col(0) - y).cwiseAbs().maxCoeff(), 1e-9);
  c.position_noise.resize(799, 1);
  EXPECT_THROW(mpmpp::simulate_closed_loop(c), mpmpp::InputError);
}

TEST(ClosedLoop, MvTargetEventsNeedTheMpc) {
  const auto c = pi_siso(100, mpmpp::EventKind::MvTarget, 10, 1.0);
  EXPECT_THROW(mpmpp::simulate_closed_loop(c), mpmpp::InputError);
}

TEST(ClosedLoop, OutliersComeFromTheirOwnStream) {
  auto clean = siso(2000, 0.05);
  auto spiked = clean;
  spiked.plant.outlier_probability = 0.01;
  spiked.plant.outlier_size = vec({1.0});
  const auto a = mpmpp::simulate_closed_loop(clean), b = mpmpp::simulate_closed_loop(spiked);
  // Identical until the first outlier, which is exactly +-1 away; the noise is unchanged.
  int first = 0;
  while (first < 2000 && a.y(first, 0) == b.y(first, 0)) ++first;
  ASSERT_LT(first, 2000);
  EXPECT_NEAR(std::abs(b.y(first, 0) - a.y(first, 0)), 1.0, 1e-12);
}
