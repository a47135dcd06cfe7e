#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "mpmpp/detector_config.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/window_features.hpp"
#include "small_loop.hpp"

using mpmpp::DetectorConfig;
using mpmpp::NoiseTest;
using mpmpp::ProcessTest;

TEST(DetectorConfig, PaperPresetsGiveTableValues) {
  auto siso = DetectorConfig::paper_siso();
  EXPECT_EQ(siso.window_samples(5.0), 1440);
  EXPECT_EQ(siso.step_samples(5.0), 60);
  EXPECT_EQ(siso.inspection_windows(), 24);
  EXPECT_EQ(siso.alarm_count(), 23);  // 23/24 = 0.958 >= 0.95 > 22/24
  EXPECT_EQ(siso.arx_order_a, 9);
  EXPECT_DOUBLE_EQ(siso.train_duration_s, 10800.0);
  auto mimo = DetectorConfig::paper_mimo();
  EXPECT_EQ(mimo.arx_order_a, 18);
  EXPECT_EQ(mimo.arx_order_b, 10);
  EXPECT_DOUBLE_EQ(mimo.train_duration_s, 14400.0);
  EXPECT_DOUBLE_EQ(siso.alpha, 1.5);  // Tables 1 and 3 verbatim
  EXPECT_DOUBLE_EQ(mimo.alpha, 1.5);
}

TEST(DetectorConfig, RecommendedPresetsDifferFromThePaperOnlyWhereDocumented) {
  auto rec_siso = DetectorConfig::preset("siso");
  auto rec_mimo = DetectorConfig::preset("mimo");
  auto pap_siso = DetectorConfig::paper_siso();
  auto pap_mimo = DetectorConfig::paper_mimo();
  pap_siso.alpha = rec_siso.alpha;
  pap_siso.train_duration_s = rec_siso.train_duration_s;
  pap_mimo.alpha = rec_mimo.alpha;
  pap_mimo.train_duration_s = rec_mimo.train_duration_s;
  pap_mimo.oe_structure = rec_mimo.oe_structure;
  pap_mimo.resampling = rec_mimo.resampling;
  pap_mimo.outlier_fraction = rec_mimo.outlier_fraction;
  pap_mimo.noise_alpha = rec_mimo.noise_alpha;
  for (DetectorConfig* c : {&pap_siso, &pap_mimo}) {  // the residual Wald tests
    c->process_test = ProcessTest::Residual;
    c->noise_test = NoiseTest::Residual;
    c->residual_steps = 3;
    c->outlier_sigmas = 5.0;
    c->threshold = 0.5;
    c->window_significance = 0.001;
    c->absent_channels = 2;  // the channels the model lacks, at a third of mimo's level
    c->absent_significance = 3e-4;
    c->model_reference_significance = 0.05;  // the model as reference where the training agrees
    c->training_confirmation = 0.05;
  }
  pap_siso.pooled_windows = 3;  // three disjoint windows pooled, at a level of 0.01
  pap_siso.window_significance = 0.01;
  pap_siso.noise_significance = 0.001;  // the noise channel's level as before
  EXPECT_EQ(rec_siso.process_test, ProcessTest::Residual);
  EXPECT_EQ(DetectorConfig::paper_siso().process_test, ProcessTest::Svm);
  EXPECT_EQ(DetectorConfig::paper_siso().noise_test, NoiseTest::Svm);
  EXPECT_EQ(DetectorConfig::from_json(rec_mimo.to_json()).noise_test, NoiseTest::Residual);
  EXPECT_EQ(rec_siso.to_json(), pap_siso.to_json());
  EXPECT_EQ(rec_mimo.to_json(), pap_mimo.to_json());
  EXPECT_GT(rec_siso.alpha, 1.5);
  EXPECT_DOUBLE_EQ(rec_siso.train_duration_s,
                   6 * 3600.0);  // before the paper's noise change at 7 h
  EXPECT_DOUBLE_EQ(rec_mimo.alpha,
                   1.25);  // below Table 3's 1.5: the window and mean covariances carry the rest
  EXPECT_DOUBLE_EQ(rec_mimo.train_duration_s, 8 * 3600.0);
  EXPECT_EQ(rec_mimo.oe_structure, mpmpp::OeStructure::Fir);
  EXPECT_EQ(rec_mimo.resampling, mpmpp::Resampling::Estimator);
  EXPECT_DOUBLE_EQ(rec_mimo.outlier_fraction, 0.05);  // fixed, not cross-validated
  EXPECT_DOUBLE_EQ(rec_mimo.noise_alpha, 5.0);
  EXPECT_DOUBLE_EQ(DetectorConfig::paper_mimo().noise_alpha, 0.0);  // 0: the same alpha
  EXPECT_EQ(pap_siso.resampling, mpmpp::Resampling::Independent);   // Sec. 4.2 as printed
  EXPECT_THROW(DetectorConfig::preset("sisoo"), mpmpp::InputError);
  EXPECT_EQ(DetectorConfig::paper_mimo().absent_channels, 0);  // the paper monitors G's channels
}

TEST(DetectorConfig, JsonRoundTripAndPresetOverrides) {
  auto c = DetectorConfig::paper_mimo();
  c.alpha = 2.25;
  c.outlier_fraction = 0.05;
  c.seed = 123456789012345ULL;
  auto back = DetectorConfig::from_json(c.to_json());
  EXPECT_EQ(back.to_json(), c.to_json());
  c.residual_ar_orders = {3, 5};
  c.residual_ma_roots = {0.0, 0.8};
  EXPECT_EQ(DetectorConfig::from_json(c.to_json()).residual_ar_orders, (std::vector<int>{3, 5}));
  EXPECT_EQ(DetectorConfig::from_json(c.to_json()).residual_ma_roots,
            (std::vector<double>{0.0, 0.8}));
  auto o = DetectorConfig::from_json(R"({"preset": "paper_mimo", "alpha": 2.0})");
  EXPECT_EQ(o.arx_order_a, 18);
  EXPECT_DOUBLE_EQ(o.alpha, 2.0);
}

TEST(DetectorConfig, PoolingLagIsTheFirstDisjointWindow) {
  auto c = DetectorConfig::siso();
  EXPECT_EQ(c.pooling_lag(5.0), 24);  // 2 h windows every 5 min
  c.step_s = 2700.0;                  // 7200 / 2700 = 2.67: the third window back is disjoint
  c.inspection_s = 8100.0;
  EXPECT_EQ(c.pooling_lag(5.0), 3);
  c.pooled_windows = 3;
  EXPECT_EQ(DetectorConfig::from_json(c.to_json()).pooled_windows, 3);
}

TEST(DetectorConfig, BadFieldsNameTheField) {
  auto expect_msg = [](const std::string& text, const std::string& field) {
    try {
      DetectorConfig::from_json(text);
      FAIL() << "no error for " << text;
    } catch (const mpmpp::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  expect_msg(R"({"alpah": 1})", "alpah");
  expect_msg(R"({"nu": 0})", "nu");
  expect_msg(R"({"threshold": 1.5})", "threshold");
  expect_msg(R"({"step_s": 7})", "inspection_s");  // 7200 s is not a whole number of 7 s steps
  expect_msg(R"({"arx_order_a": 2.5})", "arx_order_a");
  expect_msg(R"({"oe_structure": "bj"})", "oe_structure");
  expect_msg(R"({"preset": "paper_x"})", "paper_x");
  expect_msg(R"({"window_s": 1)", "JSON");
  expect_msg(R"({"preset": "siso", "pooled_windows": 0})", "pooled_windows");
  expect_msg(R"({"noise_significance": 1})", "noise_significance");
  expect_msg(R"({"preset": "mimo", "absent_channels": -1})", "absent_channels");
  expect_msg(R"({"preset": "mimo", "absent_significance": 1})", "absent_significance");
  expect_msg(R"({"preset": "mimo", "model_reference_significance": 1})",
             "model_reference_significance");
  expect_msg(R"({"preset": "mimo", "training_confirmation": 0})", "training_confirmation");
  expect_msg(R"({"preset": "siso", "residual_ar_orders": [3, 0]})", "residual_ar_orders");
  expect_msg(R"({"preset": "siso", "residual_ar_orders": 3})", "residual_ar_orders");
  expect_msg(R"({"preset": "siso", "residual_ma_roots": [0.5, 1.0]})", "residual_ma_roots");
  expect_msg(R"({"preset": "siso", "residual_ma_roots": [-0.1]})", "residual_ma_roots");
  expect_msg(R"({"preset": "siso", "residual_ma_roots": 0.5})", "residual_ma_roots");
  // One whitening order and root per output of the model.
  for (const char* key : {"residual_ar_orders", "residual_ma_roots"}) {
    DetectorConfig two = DetectorConfig::siso();
    if (std::string(key) == "residual_ar_orders")
      two.residual_ar_orders = {3, 4};
    else
      two.residual_ma_roots = {0.5, 0.7};
    try {
      mpmpp::WindowFeatures(mpmpp::test_loops::small_siso_model(), two);
      FAIL() << "no error for two entries of " << key << " on one output";
    } catch (const mpmpp::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string(key) + " has 2 entries"), std::string::npos)
          << e.what();
    }
  }
  EXPECT_THROW(DetectorConfig::paper_siso().window_samples(7.0), mpmpp::InputError);
}
