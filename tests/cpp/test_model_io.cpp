#include <gtest/gtest.h>

#include <string>

#include "mpmpp/error.hpp"
#include "mpmpp/model_io.hpp"

namespace {

const char* kGood = R"({
  "name": "t", "sample_time_s": 5.0, "inputs": ["u1", "u2"], "outputs": ["y"],
  "process": {"y": {"u1": {"num": [0.2], "den": [2.0, -1.0], "delay": 3},
                    "u2": {"gain": 1.5, "time_constant_s": 20.0, "dead_time_s": 7.5}}},
  "noise": {"y": {"num": [1.0, -0.3], "den": [1.0, 0.5]}}
})";

std::string error_of(const std::string& text) {
  try {
    mpmpp::parse_model(text, "m.json");
  } catch (const mpmpp::InputError& e) {
    return e.what();
  }
  return "(no error)";
}

std::string with(const std::string& from, const std::string& to) {
  std::string s = kGood;
  const auto at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return s.replace(at, from.size(), to);
}

}  // namespace

TEST(ModelIo, ParsesDiscreteAndFoptdChannels) {
  const mpmpp::Model m = mpmpp::parse_model(kGood, "m.json");
  ASSERT_EQ(m.num_inputs(), 2);
  ASSERT_TRUE(m.has_channel(0, 0) && m.has_channel(0, 1));
  EXPECT_DOUBLE_EQ(m.process[0][0]->num()[0], 0.1);  // normalised by den[0] = 2
  EXPECT_EQ(m.process[0][0]->delay(), 3);
  EXPECT_TRUE(*m.process[0][1] == mpmpp::TransferFunction::from_foptd(1.5, 20.0, 7.5, 5.0));
  EXPECT_DOUBLE_EQ(m.noise[0].den()[1], 0.5);
}

TEST(ModelIo, SaveLoadIsIdentical) {
  const mpmpp::Model m1 = mpmpp::parse_model(kGood, "m.json");
  const std::string text = mpmpp::model_to_json(m1);
  const mpmpp::Model m2 = mpmpp::parse_model(text, "again.json");
  EXPECT_EQ(mpmpp::model_to_json(m2), text);
  EXPECT_TRUE(*m2.process[0][1] == *m1.process[0][1]);
  EXPECT_EQ(text.find("gain"), std::string::npos);  // written in the discrete form
}

TEST(ModelIo, ErrorsNameFileAndPath) {
  EXPECT_EQ(error_of(with("\"delay\": 3", "\"delay\": 3, \"dely\": 1")),
            "m.json: process.y.u1.dely: unknown key (expected one of: num, den, delay)");
  EXPECT_EQ(error_of(with("[2.0, -1.0]", "[0.0, -1.0]")),
            "m.json: process.y.u1: den[0] must be non-zero");
  EXPECT_EQ(error_of(with("\"delay\": 3", "\"delay\": 2.5")),
            "m.json: process.y.u1.delay: must be an integer number of samples, got 2.5");
  EXPECT_EQ(
      error_of(with("[1.0, -0.3]", "[1.0, -3.0]")).rfind("m.json: noise.y: non-minimum-phase", 0),
      0u);
  EXPECT_EQ(error_of(with("\"u2\": {\"gain\"", "\"u3\": {\"gain\""))
                .rfind("m.json: process.y.u3: unknown input \"u3\"", 0),
            0u);
  EXPECT_EQ(error_of(with("\"gain\": 1.5", "\"gain\": -2e150")),
            "m.json: process.y.u2.gain: too large to compute with, got -2e+150 (magnitude 1e100 or "
            "more: its squares overflow); check the units");
  EXPECT_EQ(error_of(""), "m.json: file is empty");
  EXPECT_EQ(error_of("{\"a\": 1, \"a\": 2}"), "m.json: a: duplicate key");
  EXPECT_EQ(error_of("not json").rfind("m.json: not valid JSON: parse error at line 1", 0), 0u);
}

TEST(ModelIo, LoadsTheExampleCases) {
  const mpmpp::Model m = mpmpp::load_model(std::string(MPMPP_SOURCE_DIR) +
                                           "/examples/mimo_missing_coupling/model.json");
  EXPECT_EQ(m.num_inputs(), 2);
  EXPECT_EQ(m.num_outputs(), 2);
  EXPECT_FALSE(m.has_channel(0, 1));  // the model lacks basis_weight <- steam_pressure
  EXPECT_THROW(mpmpp::load_model("/nonexistent/model.json"), mpmpp::InputError);
}

TEST(ModelIo, ActuatorsBlockIsOptionalAndVersioned) {
  const std::string valve =
      ",\n  \"actuators\": {\"version\": 1, \"inputs\": {\"u2\": {\"kind\": \"stick_slip\", \"S\": "
      "3.9, \"J\": 1.0}}}\n}";
  std::string text = kGood;
  text.replace(text.rfind("\n}"), 2, valve);
  const mpmpp::Model m = mpmpp::parse_model(text, "m.json");
  ASSERT_FALSE(m.actuators[0].has_value());
  ASSERT_TRUE(m.actuators[1].has_value());
  EXPECT_EQ(m.actuators[1]->kind, "stick_slip");
  EXPECT_EQ(m.actuators[1]->parameters.at("S"), 3.9);
  const std::string saved = mpmpp::model_to_json(m);
  EXPECT_EQ(mpmpp::model_to_json(mpmpp::parse_model(saved, "again.json")), saved);
  // a file without the block is written without it
  EXPECT_EQ(mpmpp::model_to_json(mpmpp::parse_model(kGood, "m.json")).find("actuators"),
            std::string::npos);
  std::string future = text;
  future.replace(future.find("\"version\": 1"), 12, "\"version\": 2");
  EXPECT_EQ(error_of(future).rfind("m.json: actuators.version: version 2 is not supported", 0), 0u);
  std::string bad_j = text;
  bad_j.replace(bad_j.find("\"J\": 1.0"), 8, "\"J\": 5.0");
  EXPECT_EQ(error_of(bad_j).rfind("m.json: actuators.inputs.u2.J: must be <= S", 0), 0u);
}
