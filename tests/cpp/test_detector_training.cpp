#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "mpmpp/detector_training.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/streaming_detector.hpp"
#include "small_loop.hpp"

using namespace mpmpp;

namespace {

Model small_model() { return test_loops::small_siso_model(); }

DetectorConfig small_config() {
  DetectorConfig c = test_loops::short_window_config(1500);
  c.outlier_fraction = 0.05;
  c.resampled_models = 120;
  c.seed = 4;
  return c;
}

// random_step_samples with the process gain multiplied by `gain` from sample `change` on (a
// model-plant mismatch).
test_loops::LoopSamples plant(const Model& m, Eigen::Index n, std::uint64_t seed, double gain = 1.0,
                              Eigen::Index change = -1) {
  test_loops::LoopSamples s = test_loops::random_step_samples(m, n, seed);
  if (change >= 0)
    s.y.col(0).tail(n - change) +=
        (gain - 1.0) * m.process[0][0]->filter(s.u.col(0)).tail(n - change);
  return s;
}

bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

}  // namespace

TEST(DetectorTraining, MeanVarianceRatioAnalyticCases) {
  EXPECT_NEAR(mean_variance_ratio({0, 100, 200, 300}, 100), 0.25, 1e-15);  // disjoint: 1/n
  EXPECT_NEAR(mean_variance_ratio({0, 0, 0}, 100), 1.0, 1e-15);            // one window thrice
  EXPECT_NEAR(mean_variance_ratio({0, 50}, 100), 0.75, 1e-15);             // halves A, B, C
  EXPECT_THROW(mean_variance_ratio({}, 100), InputError);
}

TEST(DetectorTraining, OutlierOffsetRule) {
  EXPECT_EQ(outlier_offset(Eigen::VectorXd::Constant(1, 3.0), 0.1), 3.0);
  Eigen::VectorXd s(4);
  s << 4.0, 1.0, 3.0, 2.0;
  EXPECT_EQ(outlier_offset(s, 0.01), 1.5);  // at least one point flagged
  EXPECT_EQ(outlier_offset(s, 0.99), 3.5);  // never all of them
  EXPECT_EQ(outlier_offset(s, 0.5), 2.5);
  EXPECT_THROW(outlier_offset(s, 0.0), InputError);
}

TEST(DetectorTraining, ChannelSeedsAreNumpySeedSequenceWords) {
  // int(numpy.random.SeedSequence([seed, channel]).generate_state(1, numpy.uint64)[0]) >> 1
  EXPECT_EQ(channel_seed(0, 0), 7896617691693857887ULL);
  EXPECT_EQ(channel_seed(0, 1), 2918264622725855778ULL);
  EXPECT_EQ(channel_seed(7, 3), 2530781778362038830ULL);
  EXPECT_EQ(channel_seed(4294967301ULL, 2), 2485442970020027996ULL);
  EXPECT_EQ(channel_seed(9223372036854775811ULL, 1), 8281681047717283545ULL);
}

TEST(DetectorTraining, DirectionalMaxIsAtLeastBothAndExactWhenTheyCommute) {
  Eigen::Vector3d a(1.0, 2.0, 3.0), b(0.5, 4.0, 3.0);
  const Eigen::MatrixXd diag =
      directional_max(a.asDiagonal().toDenseMatrix(), b.asDiagonal().toDenseMatrix());
  EXPECT_TRUE(diag.isApprox(a.cwiseMax(b).asDiagonal().toDenseMatrix(), 1e-12));
  std::mt19937_64 rng(1);
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::MatrixXd G = Eigen::MatrixXd::NullaryExpr(3, 3, [&] { return n(rng); });
  const Eigen::MatrixXd H = Eigen::MatrixXd::NullaryExpr(3, 3, [&] { return n(rng); });
  const Eigen::MatrixXd A = G * G.transpose() + 0.1 * Eigen::MatrixXd::Identity(3, 3);
  const Eigen::MatrixXd B = H * H.transpose();
  const Eigen::MatrixXd V = directional_max(A, B);
  for (const Eigen::MatrixXd& lower : {A, B})
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(V - lower).eigenvalues().minCoeff(),
              -1e-10);
  EXPECT_THROW(directional_max(-A, B), InputError);
}

TEST(DetectorTraining, CrossValidationPicksFromTheGridWithAPermutation) {
  std::mt19937_64 rng(2);
  std::normal_distribution<double> n(0.0, 1.0);
  const RowMatrixXd X = RowMatrixXd::NullaryExpr(80, 2, [&] { return n(rng); });
  OneClassSvmOptions o;
  o.kernel_scale = 2.0;
  const OutlierFractionCv cv = cross_validate_outlier_fraction(X, {0.05, 0.1, 0.3}, 4, 9, o);
  std::vector<int> sorted = cv.order;
  std::sort(sorted.begin(), sorted.end());
  for (int i = 0; i < 80; ++i) ASSERT_EQ(sorted[i], i);
  EXPECT_TRUE(cv.outlier_fraction == 0.05 || cv.outlier_fraction == 0.1 ||
              cv.outlier_fraction == 0.3);
  EXPECT_TRUE((cv.accuracy.array() >= 0).all() && (cv.accuracy.array() <= 1).all());
  EXPECT_THROW(cross_validate_outlier_fraction(X, {0.0}, 4, 9, o), InputError);
  EXPECT_THROW(cross_validate_outlier_fraction(X, {0.1}, 1, 9, o), InputError);
  EXPECT_THROW(cross_validate_outlier_fraction(X.topRows(7), {0.1}, 4, 9, o), InputError);
}

TEST(DetectorTraining, PlantSideTrainingStreamsLikeBatchAndRetrains) {
  const Model m = small_model();
  const DetectorConfig c = small_config();
  const test_loops::LoopSamples first = plant(m, 1440, 11);  // 2 h, trained on the first 50 min
  const Detector d = train_detector(m, c, first.t, first.u, first.y, 3000.0);
  EXPECT_EQ(d.to_json(),
            train_detector(m, c, first.t, first.u, first.y, 3000.0).to_json());  // reproducible
  for (const ChannelScorer& s : d.scorers()) EXPECT_EQ(s.training_windows, 9);

  const DetectionResult batch = d.monitor(first.t, first.u, first.y);
  StreamingDetector stream(d);
  const std::vector<StreamWindow> windows = stream.push_block(first.t, first.u, first.y);
  ASSERT_EQ(static_cast<Eigen::Index>(windows.size()), batch.scores.rows());
  for (std::size_t w = 0; w < windows.size(); ++w)
    for (Eigen::Index k = 0; k < batch.scores.cols(); ++k)
      ASSERT_TRUE(same(windows[w].scores[k], batch.scores(static_cast<Eigen::Index>(w), k)));

  // The plant retrains on new normal data (a model update, a new operating point) and streams on.
  const test_loops::LoopSamples later =
      plant(m, 1440, 12, 3.0, 900);  // process gain tripled after 75 min
  const Detector retrained = train_detector(m, c, later.t, later.u, later.y, 3000.0);
  EXPECT_NE(retrained.to_json(), d.to_json());
  StreamingDetector restream(retrained);
  bool alarm = false;
  for (const StreamWindow& w : restream.push_block(later.t, later.u, later.y))
    alarm =
        alarm || std::find(w.alarm_starts.begin(), w.alarm_starts.end(), 0) != w.alarm_starts.end();
  EXPECT_TRUE(alarm);  // the tripled gain raises the process channel's alarm
}

TEST(DetectorTraining, TooFewTrainingWindowsIsAnInputErrorNamingTrainEnd) {
  const Model m = small_model();
  const test_loops::LoopSamples s = plant(m, 600, 3);
  try {
    train_detector(m, small_config(), s.t, s.u, s.y, 900.0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("train_end_s: the training period holds 2 usable windows"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(train_detector(m, small_config(), s.t, s.u, s.y, -1.0), InputError);
}
