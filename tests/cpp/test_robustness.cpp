// Hostile orders and inputs that used to crash or overflow (run under ASan/UBSan by
// `make sanitize`): each must throw InputError/NumericalError, never read out of bounds.
#include <gtest/gtest.h>

#include <climits>
#include <string>

#include "mpmpp/arx_oe.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/model_io.hpp"

namespace {

using mpmpp::InputError;
using mpmpp::NumericalError;
using mpmpp::TransferFunction;

Eigen::VectorXd ramp(Eigen::Index n) {
  return Eigen::VectorXd::LinSpaced(n, 0.0, 1.0).array().sin();
}

template <class F>
std::string input_error_of(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no InputError";
}

TEST(Robustness, ArxWithDelayIntMaxIsAnInputError) {
  // INT_MAX + nb - 1 overflowed int: t0 went negative and the regressors read before y.
  const Eigen::VectorXd y = ramp(200), u = ramp(200).reverse();
  EXPECT_NE(input_error_of([&] {
              mpmpp::arx(y, u, mpmpp::ArxOrders{2, {2}, {INT_MAX}});
            }).find("delays[0] must be <= 1000000"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] {
              mpmpp::arx(y, u, mpmpp::ArxOrders{INT_MAX, {2}, {1}});
            }).find("na must be"),
            std::string::npos);
  // Largest accepted orders on a short window: "too short", before any large allocation.
  EXPECT_THROW(mpmpp::arx(y, u, mpmpp::ArxOrders{1000000, {1000000}, {1000000}}), NumericalError);
}

TEST(Robustness, OeAndArxOeOrdersAreBounded) {
  const Eigen::VectorXd y = ramp(200), u = ramp(200).reverse();
  EXPECT_NE(input_error_of([&] {
              mpmpp::oe(y, u, {mpmpp::OeChannel{INT_MAX, INT_MAX, 0}});
            }).find("channels[0].nb must be <= 1000000"),
            std::string::npos);
  mpmpp::ArxOeConfig c;
  c.arx = mpmpp::ArxOrders{2, {2}, {1}};
  c.structures = {mpmpp::OeChannel::foptd(1)};
  c.fir_length = {
      INT_MAX};  // used to end in bad_alloc inside a reused Eigen buffer, then a double free
  EXPECT_NE(input_error_of([&] {
              mpmpp::ArxOeEstimator e(c);
            }).find("fir_length[0] must be in [1, 1000000]"),
            std::string::npos);
}

TEST(Robustness, EmptyWindowIsNotInformative) {
  mpmpp::ArxOeConfig c;
  c.arx = mpmpp::ArxOrders{2, {2}, {1}};
  c.structures = {mpmpp::OeChannel::foptd(1)};
  c.fir_length = {10};
  mpmpp::ArxOeEstimator e(c);
  EXPECT_THROW(e.estimate(Eigen::VectorXd(0), Eigen::MatrixXd(0, 1)), NumericalError);
}

TEST(Robustness, TransferFunctionDelayLimit) {
  EXPECT_THROW(TransferFunction(Eigen::VectorXd::Ones(1), Eigen::VectorXd::Ones(1), INT_MAX),
               InputError);
  const TransferFunction g(Eigen::VectorXd::Ones(1), Eigen::VectorXd::Ones(1), 1000000);
  EXPECT_THROW(g.series(g), InputError);  // 2e6 > the limit; computed without int overflow
  EXPECT_EQ(g.parallel(g).delay(), 1000000);
}

TEST(Robustness, ModelJsonNumberOverflowAndHugeNoiseModel) {
  EXPECT_NE(input_error_of([] {
              mpmpp::parse_model("{\"sample_time_s\": 1e400}", "m.json");
            }).find("m.json: not valid JSON: number overflow"),
            std::string::npos);
  std::string coefficients = "1";
  for (int k = 0; k < 300; ++k) coefficients += ", 0.0001";
  const std::string text =
      "{\"sample_time_s\": 1, \"inputs\": [\"u\"], \"outputs\": [\"y\"], \"process\": {},"
      " \"noise\": {\"y\": {\"num\": [1], \"den\": [" +
      coefficients + "]}}}";
  EXPECT_NE(input_error_of([&] {
              mpmpp::parse_model(text, "m.json");
            }).find("noise.y: at most 200 coefficients"),
            std::string::npos);
}

}  // namespace
