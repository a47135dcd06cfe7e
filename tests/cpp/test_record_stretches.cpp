// ARX, OE and ARX-OE over a record of several complete stretches (stretch_starts): each
// stretch is its own experiment from rest. Checked against analytic results: data that a
// known model generates in each stretch separately are fitted exactly (a fit that let the
// filters run on across a gap would not be), and a stretch given twice leaves the estimate
// where one copy puts it and doubles the criterion.
#include <gtest/gtest.h>

#include <limits>
#include <random>

#include "mpmpp/arx_oe.hpp"
#include "mpmpp/change_scan.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/window_features.hpp"
#include "small_loop.hpp"

namespace {

using mpmpp::TransferFunction;
using Index = Eigen::Index;

Eigen::MatrixXd white(Index n, Index m, unsigned seed) {
  std::mt19937 gen(seed);
  std::normal_distribution<double> nd;
  Eigen::MatrixXd x(n, m);
  for (Index i = 0; i < x.size(); ++i) x.data()[i] = nd(gen);
  return x;
}

// y = sum_j g_j u_j simulated from rest in each stretch (rows [starts[k], starts[k+1])).
Eigen::VectorXd simulate_stretches(const std::vector<TransferFunction>& g, const Eigen::MatrixXd& u,
                                   const std::vector<Index>& starts) {
  Eigen::VectorXd y = Eigen::VectorXd::Zero(u.rows());
  std::vector<Index> bounds{0};
  bounds.insert(bounds.end(), starts.begin(), starts.end());
  bounds.push_back(u.rows());
  for (std::size_t k = 0; k + 1 < bounds.size(); ++k) {
    const Index a = bounds[k], n = bounds[k + 1] - a;
    for (std::size_t j = 0; j < g.size(); ++j)
      y.segment(a, n) += g[j].filter(u.col(static_cast<Index>(j)).segment(a, n));
  }
  return y;
}

Eigen::VectorXd twice(const Eigen::VectorXd& x) {
  Eigen::VectorXd out(2 * x.size());
  out << x, x;
  return out;
}

Eigen::MatrixXd twice(const Eigen::MatrixXd& x) {
  Eigen::MatrixXd out(2 * x.rows(), x.cols());
  out << x, x;
  return out;
}

TEST(RecordStretches, ArxFitsDataGeneratedPerStretchExactly) {
  const Eigen::MatrixXd u = white(500, 2, 1);
  const Eigen::Vector3d a(1.0, -0.5, 0.2);
  const std::vector<TransferFunction> g{TransferFunction(Eigen::Vector2d(0.4, 0.1), a, 3),
                                        TransferFunction(Eigen::VectorXd::Constant(1, -0.3), a, 1)};
  const std::vector<Index> starts{120, 300};
  const Eigen::VectorXd y = simulate_stretches(g, u, starts);
  const mpmpp::ArxOrders orders{2, {2, 1}, {3, 1}};
  const auto r = mpmpp::arx(y, u, orders, {}, starts);
  EXPECT_NEAR(r.a[1], -0.5, 1e-12);
  EXPECT_NEAR(r.a[2], 0.2, 1e-12);
  EXPECT_NEAR(r.b[0][1], 0.1, 1e-12);
  EXPECT_NEAR(r.b[1][0], -0.3, 1e-12);
  EXPECT_EQ(r.equations, 500 - 3 * 4);  // t0 = 4 rows into each of the three stretches
  // As one stretch the rows after each break do not follow the model: not an exact fit.
  EXPECT_GT(mpmpp::arx(y, u, orders).noise_variance, 1e-6);
}

TEST(RecordStretches, ArxOfAStretchGivenTwiceIsTheArxOfOneCopy) {
  const Eigen::MatrixXd u = white(400, 1, 2);
  const Eigen::VectorXd y =
      TransferFunction(Eigen::VectorXd::Constant(1, 0.2), Eigen::Vector2d(1.0, -0.8), 2)
          .filter(u.col(0)) +
      0.3 * white(400, 1, 3).col(0);
  const mpmpp::ArxOrders orders{3, {2}, {2}};
  const auto one = mpmpp::arx(y, u, orders);
  const auto two = mpmpp::arx(twice(y), twice(u), orders, {}, {400});
  EXPECT_LT((one.theta - two.theta).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_EQ(two.equations, 2 * one.equations);
}

TEST(RecordStretches, OeFitsDataGeneratedPerStretchExactly) {
  const Eigen::MatrixXd u = white(900, 2, 4);
  const std::vector<TransferFunction> g{
      TransferFunction(Eigen::VectorXd::Constant(1, 0.1003), Eigen::Vector2d(1.0, -0.9048), 7),
      TransferFunction(Eigen::Vector2d(0.3, 0.1), Eigen::Vector3d(1.0, -1.1, 0.3), 2)};
  const std::vector<Index> starts{250, 260, 600};  // a 10-row stretch too: shorter than the lags
  const Eigen::VectorXd y = simulate_stretches(g, u, starts);
  const std::vector<mpmpp::OeChannel> channels{mpmpp::OeChannel::foptd(7), {2, 2, 2}};
  const auto r = mpmpp::oe(y, u, channels, 0, {}, starts);
  ASSERT_TRUE(r.converged);
  EXPECT_NEAR(r.b[0][0], 0.1003, 1e-9);
  EXPECT_NEAR(r.f[0][1], -0.9048, 1e-9);
  EXPECT_NEAR(r.b[1][1], 0.1, 1e-9);
  EXPECT_NEAR(r.f[1][2], 0.3, 1e-9);
  EXPECT_EQ(r.equations, 900);
  EXPECT_GT(mpmpp::oe(y, u, channels).cost, 1e-6);  // one stretch: the breaks do not fit
}

TEST(RecordStretches, OeAndArxOeOfAStretchGivenTwiceAreTheFitsOfOneCopy) {
  const Eigen::MatrixXd u = white(600, 1, 5);
  const TransferFunction g(Eigen::VectorXd::Constant(1, 0.15), Eigen::Vector2d(1.0, -0.85), 3);
  const TransferFunction h(Eigen::VectorXd::Ones(1), Eigen::Vector2d(1.0, -0.6), 0);
  const Eigen::VectorXd y = g.filter(u.col(0)) + 0.2 * h.filter(white(600, 1, 6).col(0));
  const std::vector<mpmpp::OeChannel> channels{mpmpp::OeChannel::foptd(3)};
  const auto one = mpmpp::oe(y, u, channels, 4);
  const auto two = mpmpp::oe(twice(y), twice(u), channels, 4, {}, {600});
  EXPECT_LT((one.theta - two.theta).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_NEAR(two.cost, 2.0 * one.cost, 1e-8 * one.cost);
  EXPECT_EQ(two.equations, 2 * one.equations);

  mpmpp::ArxOeConfig c;
  c.arx = {4, {5}, {3}};
  c.structures = channels;
  c.fir_length = {40};
  mpmpp::ArxOeEstimator est(c);
  const auto r1 = est.estimate(y, u);
  const auto r2 = est.estimate(twice(y), twice(u), {600});
  EXPECT_LT((r1.noise - r2.noise).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_LT((r1.oe.theta - r2.oe.theta).cwiseAbs().maxCoeff(), 1e-8);
  EXPECT_EQ(r2.oe.equations, 2 * r1.oe.equations);
  EXPECT_EQ(r2.arx.equations, 2 * r1.arx.equations);
}

TEST(RecordStretches, BadStretchesAreRefusedWithTheirReason) {
  const Eigen::MatrixXd u = white(300, 1, 7);
  const Eigen::VectorXd y = u.col(0) + 0.1 * white(300, 1, 8).col(0);
  const mpmpp::ArxOrders orders{2, {2}, {1}};
  for (const std::vector<Index>& starts :
       {std::vector<Index>{0}, std::vector<Index>{300}, std::vector<Index>{200, 100},
        std::vector<Index>{100, 100}})
    EXPECT_THROW(mpmpp::arx(y, u, orders, {}, starts), mpmpp::InputError);
  // Two-row stretches leave no equation (t0 = 2), however long the record.
  std::vector<Index> every_second;
  for (Index s = 2; s < 300; s += 2) every_second.push_back(s);
  EXPECT_THROW(mpmpp::arx(y, u, orders, {}, every_second), mpmpp::NumericalError);

  mpmpp::ArxOeConfig c;
  c.arx = orders;
  c.structures = {mpmpp::OeChannel::foptd(1)};
  c.fir_length = {20};
  c.detrend = mpmpp::Detrend::Linear;
  EXPECT_THROW(mpmpp::ArxOeEstimator(c).estimate(y, u, {150}), mpmpp::InputError);
}

// The paper's per-window ARX-OE (no residual regression, no covariances) with a few rows
// missing: the window's features are the ARX-OE of its complete rows laid end to end, a new
// stretch after each gap; beyond a tenth of the window missing, the window is skipped.
TEST(RecordStretches, APaperWindowWithMissingRowsIsFittedOnItsCompleteRows) {
  const mpmpp::Model model = mpmpp::test_loops::small_siso_model(3);
  const mpmpp::DetectorConfig config = mpmpp::test_loops::short_window_config(600.0);
  mpmpp::WindowFeatures features(model, config);
  const Index W = features.window_samples();
  Eigen::MatrixXd u = white(W, 1, 9);
  Eigen::MatrixXd y(W, 1);
  y.col(0) = model.process[0][0]->filter(u.col(0)) + 0.1 * white(W, 1, 10).col(0);
  y(40, 0) = y(41, 0) = NAN;  // two output samples lost
  u(90, 0) = NAN;             // and one input sample
  std::vector<Eigen::VectorXd> f;
  std::string reason;
  ASSERT_TRUE(features.extract(u, y, f, &reason)) << reason;

  std::vector<Index> rows;
  for (Index t = 0; t < W; ++t)
    if (t != 40 && t != 41 && t != 90) rows.push_back(t);
  mpmpp::ArxOeConfig c;
  c.arx = {config.arx_order_a, {config.arx_order_b + 1}, {3}};
  c.arx_options.delta = config.arx_regularisation;
  c.structures = {mpmpp::OeChannel::fir(config.fir_length, 3)};
  c.fir_length = {3 + config.fir_length};
  const Eigen::VectorXd y_rows = y.col(0)(rows);
  const Eigen::MatrixXd u_rows = u(rows, Eigen::all);
  const auto r = mpmpp::ArxOeEstimator(c).estimate(y_rows, u_rows, {40, 88});
  for (std::size_t k = 0; k < features.channels().size(); ++k) {
    const Eigen::VectorXd expected =
        features.channels()[k].kind == mpmpp::MonitoredChannel::Kind::Process
            ? Eigen::VectorXd(r.channels[0].fir.tail(config.fir_length))
            : Eigen::VectorXd(r.noise);
    EXPECT_LT((f[k] - expected).cwiseAbs().maxCoeff(), 1e-12);
  }
  for (Index t = 0; t < W / 10 - 2; ++t) y(2 * t + 1, 0) = NAN;  // now more than a tenth
  EXPECT_FALSE(features.extract(u, y, f, &reason));
  EXPECT_EQ(reason, "missing values in the window");
}

// fit_ar over a series with lost samples (NaN): rows whose lags reach one are left out. An
// AR(2) recursion restarted after each gap is fitted exactly; with span 5 the rows are those
// whose five lags are present, as a plain least-squares sum over them gives.
TEST(RecordStretches, ArFitLeavesOutTheRowsThatReadALostSample) {
  const Index n = 600;
  const Eigen::MatrixXd w = white(n, 1, 7);
  Eigen::VectorXd e(n);
  for (Index t = 0; t < n; ++t) {
    const bool restart = t < 2 || t % 97 < 2;  // a gap at every 97th row, the recursion anew
    e[t] = restart ? w(t, 0) : 1.2 * e[t - 1] - 0.5 * e[t - 2];
  }
  for (Index t = 97; t < n; t += 97) e[t - 1] = std::numeric_limits<double>::quiet_NaN();
  const Eigen::VectorXd exact = mpmpp::fit_ar(e, 2, 0, n);
  EXPECT_NEAR(exact[1], -1.2, 1e-10);
  EXPECT_NEAR(exact[2], 0.5, 1e-10);

  Eigen::VectorXd noisy = e + 0.1 * white(n, 1, 8).col(0);
  Eigen::Matrix2d gram = Eigen::Matrix2d::Zero();
  Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
  for (Index t = 5; t < n; ++t) {
    if (!noisy.segment(t - 5, 6).allFinite()) continue;
    const Eigen::Vector2d lag(noisy[t - 1], noisy[t - 2]);
    gram += lag * lag.transpose();
    rhs += lag * noisy[t];
  }
  const Eigen::Vector2d a = gram.ldlt().solve(rhs);
  const Eigen::VectorXd fit = mpmpp::fit_ar(noisy, 2, 0, n, 5);
  EXPECT_NEAR(fit[1], -a[0], 1e-12);
  EXPECT_NEAR(fit[2], -a[1], 1e-12);
}

}  // namespace
