#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "mpmpp/detector.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/mismatch_indicator.hpp"
#include "mpmpp/model_io.hpp"
#include "small_loop.hpp"

using namespace mpmpp;

namespace {

Model siso_model() { return test_loops::small_siso_model(17); }

// A scorer with random support vectors: the file format does not care how it was trained.
// decorrelated: with a random lower-triangular feature_decorrelation (Resampling::Covariance).
ChannelScorer random_scorer(int d, std::mt19937_64& rng, bool decorrelated) {
  std::normal_distribution<double> n(0.0, 1.0);
  ChannelScorer s;
  s.feature_mean = Eigen::VectorXd::NullaryExpr(d, [&] { return 0.01 * n(rng); });
  s.feature_scale = Eigen::VectorXd::NullaryExpr(d, [&] { return 0.001 + std::abs(n(rng)); });
  if (decorrelated)
    s.feature_decorrelation =
        Eigen::MatrixXd::NullaryExpr(d, d, [&] { return n(rng); }).triangularView<Eigen::Lower>();
  s.support_vectors = RowMatrixXd::NullaryExpr(7, d, [&] { return n(rng) / 3.0; });
  s.dual_coef =
      Eigen::VectorXd::NullaryExpr(7, [&] { return 0.1 + 0.9 * std::abs(std::tanh(n(rng))); });
  s.offset = 0.123456789012345678;
  s.kernel_scale = 1.0;
  s.nu = 0.5;
  s.n_train = 14;
  s.training_windows = 13;
  s.outlier_fraction = 0.05;
  s.cv_accuracy = 0.9498;
  return s;
}

Detector random_detector() {
  std::mt19937_64 rng(42);
  Model m = siso_model();
  DetectorConfig c = DetectorConfig::paper_siso();
  WindowFeatures f(m, c);
  std::vector<ChannelScorer> scorers;
  for (size_t k = 0; k < f.channels().size(); ++k)
    scorers.push_back(random_scorer(f.feature_length(k), rng, k == 0));
  return Detector(m, c, 10800.0, scorers);
}

std::string temp_path(const char* name) { return std::string(::testing::TempDir()) + name; }

}  // namespace

TEST(Detector, ChannelsAndFeatureLengths) {
  WindowFeatures f(siso_model(), DetectorConfig::paper_siso());
  ASSERT_EQ(f.channels().size(), 2u);
  EXPECT_EQ(f.channels()[0].kind, MonitoredChannel::Kind::Process);
  EXPECT_EQ(f.channels()[1].kind, MonitoredChannel::Kind::Noise);
  // 0.1003 * 0.9048^k >= 1% of 0.1003 for k <= 46: 47 coefficients after the delay.
  EXPECT_EQ(f.feature_length(0), 47);
  EXPECT_EQ(f.feature_length(1), 9);
}

TEST(Detector, SaveLoadRoundTripIsExact) {
  Detector d = random_detector();
  const std::string path = temp_path("detector_roundtrip.json");
  d.save(path);
  Detector back = Detector::load(path);
  EXPECT_EQ(back.to_json(), d.to_json());
  std::mt19937_64 rng(1);
  std::normal_distribution<double> n(0.0, 0.02);
  for (size_t k = 0; k < d.scorers().size(); ++k) {
    const int m = static_cast<int>(d.scorers()[k].feature_mean.size());
    Eigen::MatrixXd X = Eigen::MatrixXd::NullaryExpr(20, m, [&] { return n(rng); });
    Eigen::VectorXd a = d.scorers()[k].score_rows(X), b = back.scorers()[k].score_rows(X);
    for (int r = 0; r < X.rows(); ++r) EXPECT_EQ(a[r], b[r]);  // bit-identical
    // eq. 20 written out: h = (sum_i a_i exp(-||sv_i - z||^2 / c) - offset) / (nu l)
    const ChannelScorer& s = d.scorers()[k];
    Eigen::VectorXd z = (X.row(3).transpose() - s.feature_mean).cwiseQuotient(s.feature_scale);
    if (s.feature_decorrelation.size() != 0) z = s.feature_decorrelation * z;
    double sum = 0;
    for (int i = 0; i < s.support_vectors.rows(); ++i)
      sum += s.dual_coef[i] *
             std::exp(-(s.support_vectors.row(i).transpose() - z).squaredNorm() / s.kernel_scale);
    EXPECT_NEAR(a[3], (sum - s.offset) / (s.nu * s.n_train), 1e-12);
  }
  EXPECT_EQ(back.scorers()[0].feature_decorrelation, d.scorers()[0].feature_decorrelation);
  std::remove(path.c_str());
}

namespace {

// doc as a file of `version`: refused with the missing field named.
void expect_required_field(nlohmann::json doc, int version, const std::string& field) {
  doc["version"] = version;
  try {
    Detector::from_json(doc.dump(), "v" + std::to_string(version) + ".json");
    ADD_FAILURE() << "a version " << version << " file without " << field << " loaded";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing field '" + field + "'"), std::string::npos)
        << e.what();
  }
}

}  // namespace

TEST(Detector, VersionOneFilesLoadWithoutDecorrelation) {
  nlohmann::json doc = nlohmann::json::parse(random_detector().to_json());
  doc["version"] = 1;  // written before feature_decorrelation existed
  for (auto& c : doc["channels"]) c.erase("feature_decorrelation");
  for (auto& c : doc["channels"]) c.erase("reference_covariance");  // version 3
  for (auto& c : doc["channels"]) c.erase("mean_covariance");       // version 4
  const Detector old = Detector::from_json(doc.dump(), "v1.json");
  for (const ChannelScorer& s : old.scorers()) EXPECT_EQ(s.feature_decorrelation.size(), 0);
  expect_required_field(doc, 2, "feature_decorrelation");
}

TEST(Detector, VersionTwoAndThreeFilesLoadWithoutTheLaterCovariances) {
  nlohmann::json doc = nlohmann::json::parse(random_detector().to_json());
  doc["version"] = 3;
  for (auto& c : doc["channels"]) c.erase("mean_covariance");
  const Detector v3 =
      Detector::from_json(doc.dump(), "v3.json");  // named: a temporary would die before the loop
  for (const ChannelScorer& s : v3.scorers()) EXPECT_EQ(s.mean_covariance.size(), 0);
  expect_required_field(doc, 4, "mean_covariance");
  doc["version"] = 2;
  for (auto& c : doc["channels"]) c.erase("reference_covariance");
  const Detector v2 = Detector::from_json(doc.dump(), "v2.json");
  for (const ChannelScorer& s : v2.scorers()) EXPECT_EQ(s.reference_covariance.size(), 0);
  expect_required_field(doc, 3, "reference_covariance");
}

// The training mean's own covariance C_mean adds to every window's: scoring (x, C) with
// mean_covariance M is scoring (x, C + M) without it; the file keeps M exactly.
TEST(Detector, MeanCovarianceAddsToTheWindowCovariance) {
  std::mt19937_64 rng(9);
  ChannelScorer exact_mean = random_scorer(2, rng, true);
  Eigen::MatrixXd C(2, 2), M(2, 2);
  C << 4e-5, -3e-5, -3e-5, 3e-5;
  M << 1e-5, 2e-6, 2e-6, 5e-6;
  exact_mean.reference_covariance = C + M;
  ChannelScorer with_mean = exact_mean;
  with_mean.mean_covariance = M;
  std::normal_distribution<double> n(0.0, 0.01);
  for (int r = 0; r < 10; ++r) {
    const Eigen::VectorXd x =
        exact_mean.feature_mean + Eigen::VectorXd::NullaryExpr(2, [&] { return n(rng); });
    EXPECT_NEAR(with_mean.score(x, C), exact_mean.score(x, C + M), 1e-12);
  }
  // A window like the training ones (C = C_ref - C_mean) is mapped onto itself.
  const Eigen::VectorXd x = exact_mean.feature_mean + Eigen::Vector2d(0.004, -0.002);
  ChannelScorer plain = exact_mean;
  plain.reference_covariance.resize(0, 0);
  EXPECT_NEAR(with_mean.score(x, C), plain.score(x), 1e-12);

  ChannelScorer orphan = with_mean;
  orphan.reference_covariance.resize(0, 0);  // C_mean only makes sense with C_ref
  EXPECT_THROW(orphan.validate(2, "channel"), InputError);
  ChannelScorer asymmetric = with_mean;
  asymmetric.mean_covariance(0, 1) += 1.0;
  EXPECT_THROW(asymmetric.validate(2, "channel"), InputError);
}

// The model as reference (ChannelScorer::confirmation): score = log10 max(p_0 / level,
// p / confirmation), p_0 of x ~ N(0, C) and p of x - mean ~ N(0, C + C_mean). One coefficient,
// C = C_mean = 1, mean 0.5: chi-square(1) tails are erfc(|z| / sqrt 2), analytic.
TEST(Detector, ModelReferenceIsAnIntersectionUnionTest) {
  ChannelScorer s;
  s.feature_mean = Eigen::VectorXd::Constant(1, 0.5);
  s.feature_scale = Eigen::VectorXd::Ones(1);
  s.reference_covariance = Eigen::MatrixXd::Constant(1, 1, 2.0);
  s.mean_covariance = Eigen::MatrixXd::Ones(1, 1);
  s.significance = 0.01;
  ChannelScorer referenced = s;
  referenced.confirmation = 0.5;
  referenced.validate(1, "channel");
  const Eigen::MatrixXd C = Eigen::MatrixXd::Ones(1, 1);
  auto tail = [](double z) { return std::erfc(std::abs(z) / std::sqrt(2.0)); };
  for (double x : {0.6, 3.0, 8.0}) {
    const double p0 = tail(x), p = tail((x - 0.5) / std::sqrt(2.0));
    const Eigen::VectorXd v = Eigen::VectorXd::Constant(1, x);
    EXPECT_NEAR(s.score(v, C), std::log10(p / 0.01), 1e-9) << x;
    EXPECT_NEAR(referenced.score(v, C), std::log10(std::max(p0 / 0.01, p / 0.5)), 1e-9) << x;
  }
  // x = 3: the model rejects (p_0 = 0.0027) but the training does not (p = 0.077 > 0.01),
  // and with the confirmation at 0.5 the window is negative.
  EXPECT_GT(s.score(Eigen::VectorXd::Constant(1, 3.0), C), 0);
  EXPECT_LT(referenced.score(Eigen::VectorXd::Constant(1, 3.0), C), 0);
  ChannelScorer svm = referenced;
  svm.significance = 0;  // the SVM path has no model reference
  EXPECT_THROW(svm.validate(1, "channel"), InputError);
  ChannelScorer over = referenced;
  over.confirmation = 1.5;
  EXPECT_THROW(over.validate(1, "channel"), InputError);
}

// Resampling::Estimator: the window's deviation is carried into the training precision,
// x <- mean + C_ref^1/2 C^-1/2 (x - mean). Analytic cases: C = C_ref is the identity map,
// C = C_ref / 4 doubles the deviation; and the file keeps C_ref exactly.
TEST(Detector, ReferenceCovarianceMapsTheDeviationAndRoundTrips) {
  std::mt19937_64 rng(5);
  ChannelScorer plain = random_scorer(3, rng, true);
  ChannelScorer mapped = plain;
  Eigen::MatrixXd L(3, 3);
  L << 2e-3, 0, 0, -1e-3, 1e-3, 0, 5e-4, 2e-4, 3e-3;
  mapped.reference_covariance = L * L.transpose();
  std::normal_distribution<double> n(0.0, 0.01);
  for (int r = 0; r < 10; ++r) {
    const Eigen::VectorXd x =
        plain.feature_mean + Eigen::VectorXd::NullaryExpr(3, [&] { return n(rng); });
    EXPECT_NEAR(mapped.score(x, mapped.reference_covariance), plain.score(x), 1e-12);
    const Eigen::MatrixXd quarter = mapped.reference_covariance / 4.0;
    EXPECT_NEAR(mapped.score(x, quarter),
                plain.score(plain.feature_mean + 2.0 * (x - plain.feature_mean)), 1e-12);
  }
  EXPECT_THROW(mapped.score(plain.feature_mean), InputError);  // the window covariance is required
  EXPECT_THROW(mapped.score(plain.feature_mean, Eigen::MatrixXd::Identity(2, 2)), InputError);
  EXPECT_TRUE(std::isnan(mapped.score(plain.feature_mean, -Eigen::MatrixXd::Identity(3, 3))));

  Model m = siso_model();
  DetectorConfig c = DetectorConfig::mimo();  // FIR OE: the estimator's covariance is the features'
  c.resampling = Resampling::Estimator;
  WindowFeatures f(m, c);
  std::vector<ChannelScorer> scorers;
  for (size_t k = 0; k < f.channels().size(); ++k) {
    scorers.push_back(random_scorer(f.feature_length(static_cast<int>(k)), rng, true));
    if (f.channels()[k].kind == MonitoredChannel::Kind::Process) {
      const int d = f.feature_length(static_cast<int>(k));
      const Eigen::MatrixXd a = Eigen::MatrixXd::NullaryExpr(d, d, [&] { return n(rng); });
      scorers.back().reference_covariance =
          a * a.transpose() + 1e-4 * Eigen::MatrixXd::Identity(d, d);
      scorers.back().mean_covariance = 0.25 * scorers.back().reference_covariance;
    }
  }
  const Detector d(m, c, 7200.0, scorers);
  const Detector back = Detector::from_json(d.to_json(), "estimator.json");
  EXPECT_EQ(back.to_json(), d.to_json());
  EXPECT_EQ(back.scorers()[0].reference_covariance, d.scorers()[0].reference_covariance);
  EXPECT_EQ(back.scorers()[0].mean_covariance, d.scorers()[0].mean_covariance);
  EXPECT_EQ(back.config().resampling, Resampling::Estimator);
  ChannelScorer asymmetric = scorers[0];
  asymmetric.reference_covariance(0, 1) += 1.0;
  EXPECT_THROW(asymmetric.validate(f.feature_length(0), "channel"), InputError);
}

TEST(Detector, CorruptTruncatedOrNewerFilesAreClearErrors) {
  const std::string text = random_detector().to_json();
  auto expect_error = [](const std::string& body, const std::string& needle) {
    try {
      Detector::from_json(body, "det.json");
      FAIL() << "no error, expected " << needle;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    }
  };
  expect_error(text.substr(0, text.size() / 2), "truncated or corrupt");
  expect_error("", "truncated or corrupt");
  std::string newer = text;
  const std::string current = "\"version\": " + std::to_string(Detector::kFormatVersion);
  const std::string next = std::to_string(Detector::kFormatVersion + 1);
  newer.replace(newer.find(current), current.size(), "\"version\": " + next);
  expect_error(newer, "version " + next);
  std::string foreign = text;
  foreign.replace(foreign.find("mpmpp-detector"), 14, "something-else");
  expect_error(foreign, "not an mpmpp detector file");
  std::string missing = text;
  missing.replace(missing.find("\"offset\""), 8, "\"offzet\"");
  expect_error(missing, "missing field 'offset'");
  EXPECT_THROW(Detector::load(temp_path("does_not_exist.json")), InputError);
}

TEST(Detector, MonitorScoresZeroInTrainingAndAlarmsFollowIndicator) {
  Detector d = random_detector();
  const int n_windows = 60, n_ch = 2;
  WindowFeatures::Series s;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int w = 0; w < n_windows; ++w) {
    FeatureWindow fw;
    fw.first = 60 * w;
    fw.start_s = 300.0 * w;
    fw.end_s = fw.start_s + 7200.0;
    fw.skipped = (w == 40);
    s.windows.push_back(fw);
  }
  for (int k = 0; k < n_ch; ++k) {
    const int m = static_cast<int>(d.scorers()[k].feature_mean.size());
    Eigen::MatrixXd F = Eigen::MatrixXd::NullaryExpr(n_windows, m, [&] { return n(rng); });
    F.row(40).setConstant(std::nan(""));
    s.features.push_back(F);
  }
  DetectionResult r = d.monitor(s);
  for (int w = 0; w < n_windows; ++w) {
    EXPECT_EQ(r.training[w], s.windows[w].end_s <= 10800.0);
    if (r.training[w]) EXPECT_EQ(r.scores(w, 0), 0.0);
  }
  EXPECT_TRUE(std::isnan(r.scores(40, 0)));
  for (int k = 0; k < n_ch; ++k) {
    MismatchIndicator ind(24, 23);
    for (int w = 0; w < n_windows; ++w) {
      auto u = ind.push(r.scores(w, k));
      EXPECT_EQ(r.indicator(w, k), u.indicator);
      bool listed = false;
      for (const auto& a : r.alarms) listed |= (a.channel == k && a.window == w);
      EXPECT_EQ(listed, u.started);
    }
  }
}

// The streaming path (score_window per window with the caller's workspace) gives exactly the
// batch monitor() scores on simulated open-loop data (white-noise input through G, H e noise).
TEST(Detector, ScoreWindowEqualsBatchMonitor) {
  Detector d = random_detector();
  const Model& m = d.model();
  const int n = 1440 + 40 * 60;
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd u = Eigen::VectorXd::NullaryExpr(n, [&] { return normal(rng); });
  Eigen::VectorXd e = Eigen::VectorXd::NullaryExpr(n, [&] { return 0.05 * normal(rng); });
  Eigen::VectorXd y = m.process[0][0]->filter(u) + m.noise[0].filter(e);
  Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(n, 0.0, 5.0 * (n - 1));
  DetectionResult batch = d.monitor(t, u, y);
  ASSERT_EQ(batch.windows.size(), 41u);
  int scored = 0;
  WindowFeatures features = d.make_features();
  for (size_t w = 0; w < batch.windows.size(); ++w) {
    const int first = batch.windows[w].first;
    Eigen::VectorXd h = d.score_window(features, u.segment(first, 1440), y.segment(first, 1440));
    for (int k = 0; k < h.size(); ++k) {
      if (batch.training[w])
        EXPECT_EQ(batch.scores(w, k), 0.0);
      else {
        EXPECT_EQ(h[k], batch.scores(w, k)) << w << " " << k;  // bit-identical
        ++scored;
      }
    }
  }
  EXPECT_EQ(scored, 2 * 28);  // windows ending after 3 h: 41 - 13
  // A window does without a lost sample (fitted on its complete rows); a gap of more than a
  // tenth of it is skipped with a reason.
  y[100] = std::nan("");
  std::string reason;
  Eigen::VectorXd h = d.score_window(features, u.head(1440), y.head(1440), &reason);
  EXPECT_TRUE(h.allFinite()) << reason;
  y.segment(200, 150).setConstant(std::nan(""));
  h = d.score_window(features, u.head(1440), y.head(1440), &reason);
  EXPECT_TRUE(std::isnan(h[0]) && std::isnan(h[1]));
  EXPECT_NE(reason.find("missing"), std::string::npos);
}
