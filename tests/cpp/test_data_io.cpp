#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "mpmpp/data_io.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/model_io.hpp"

namespace {

mpmpp::Model small_model() { return mpmpp::make_model("m", 5.0, {"u"}, {"y"}, {}, {}); }

std::string error_of(const std::string& csv) {
  try {
    mpmpp::validate_data(mpmpp::parse_csv(csv, "d.csv"), small_model(), "d.csv");
  } catch (const mpmpp::InputError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(DataIo, ReadsValuesAndCountsMissing) {
  const mpmpp::DataTable d =
      mpmpp::parse_csv("time,u,y,x\n0,1.5,,2\n5,NaN,2e-3,\n10,-1,3,4\n", "d.csv");
  ASSERT_EQ(d.num_samples(), 3);
  EXPECT_EQ(d.columns, (std::vector<std::string>{"u", "y", "x"}));
  EXPECT_EQ(d.missing, (std::vector<int>{1, 1, 1}));
  EXPECT_DOUBLE_EQ(d.values(1, 1), 2e-3);
  EXPECT_TRUE(std::isnan(d.values(0, 1)));
  EXPECT_DOUBLE_EQ(d.time_s[2], 10.0);
}

TEST(DataIo, IsoTimestampsAreSecondsSinceTheFirst) {
  const mpmpp::DataTable d = mpmpp::parse_csv(
      "time,u,y\n2023-12-31T23:59:55Z,1,1\n2024-01-01T01:00:00+01:00,1,1\n", "d.csv");
  EXPECT_EQ(d.time_origin, "2023-12-31T23:59:55Z");
  EXPECT_DOUBLE_EQ(d.time_s[1], 5.0);
}

TEST(DataIo, HistorianStatusWordsInANumericColumnAreMissingAndCounted) {
  const mpmpp::DataTable d = mpmpp::parse_csv(
      "time,u,y\n0,1,2\n5,Bad Input,3\n10,2,I/O Timeout\n15,3,4\n20,Shutdown,5\n25,4,6\n", "d.csv");
  ASSERT_EQ(d.columns, (std::vector<std::string>{"u", "y"}));
  EXPECT_TRUE(std::isnan(d.values(1, 0)) && std::isnan(d.values(4, 0)) &&
              std::isnan(d.values(2, 1)));
  EXPECT_DOUBLE_EQ(d.values(5, 0), 4.0);
  EXPECT_EQ(d.missing, (std::vector<int>{2, 1}));
  ASSERT_EQ(d.repairs.status_words.size(), 2u);
  EXPECT_EQ(d.repairs.status_words[0].column, "u");
  EXPECT_EQ(d.repairs.status_words[0].cells, 2);
  EXPECT_EQ(d.repairs.status_words[0].first, "Bad Input");
  EXPECT_EQ(d.repairs.status_words[1].first, "I/O Timeout");
  // As many words as numbers: not a numeric column; a number written wrongly or an infinity
  // is an error however many numbers surround it.
  EXPECT_EQ(error_of("time,u,y\n0,1,2\n5,Bad,2\n"),
            "d.csv: row 3, column u: \"Bad\" is not a number");
  EXPECT_EQ(error_of("time,u,y\n0,1,2\n5,2,2\n10,\"12,5\",2\n"),
            "d.csv: row 4, column u: \"12,5\" is not a number");
  EXPECT_EQ(error_of("time,u,y\n0,1,2\n5,2,2\n10,-inf,2\n"),
            "d.csv: row 4, column u: \"-inf\" is not a number");
  // A number too large to square and sum is refused where it is written, not met later as an
  // infinity inside a fit; the largest value allowed reads as written.
  EXPECT_EQ(error_of("time,u,y\n0,1,2\n5,2,-1e100\n"),
            "d.csv: row 3, column y: \"-1e100\" is too large to compute with (magnitude 1e100 or "
            "more: its squares overflow); check the column's units");
  EXPECT_DOUBLE_EQ(mpmpp::parse_csv("time,u\n0,9.9e99\n", "d.csv").values(0, 0), 9.9e99);
}

TEST(DataIo, ErrorsNameFileRowAndColumn) {
  EXPECT_EQ(error_of("time,u,y\n0,1,2\n5,x,2\n"), "d.csv: row 3, column u: \"x\" is not a number");
  EXPECT_EQ(error_of("time,u\n0,1\n"),
            "d.csv: column \"y\" (model output) is missing (columns: time, u)");
  EXPECT_EQ(error_of("time,u,y\n0,1,2\n6,1,2\n"),
            "d.csv: row 3, column time: time step 6 s from the previous row, expected the model's "
            "sample_time_s = 5 s");
  EXPECT_EQ(error_of("time,u,y,y\n0,1,2,3\n"),
            "d.csv: row 1: duplicate column \"y\" (columns 3 and 4)");
  EXPECT_EQ(error_of(""), "d.csv: file is empty");
  EXPECT_EQ(
      error_of("time,u,y\n0,1,2\n0,1,2\n").rfind("d.csv: row 3, column time: 0 s is not after", 0),
      0u);
  EXPECT_EQ(error_of("time,u,y\n0,1,2\n5.000001,1,2\n"), "(no error)");  // within 1e-6 relative
}

TEST(DataIo, WriteReadRoundTripIsExact) {
  Eigen::VectorXd t(3);
  t << 0.0, 0.1, 0.2;
  Eigen::MatrixXd v(3, 2);
  v << 1.0 / 3.0, std::nan(""), -2.5e-300, 7.0, 1e17, 0.1;
  const mpmpp::DataTable d = mpmpp::make_data_table(t, {"a", "b,c"}, v);
  const mpmpp::DataTable back = mpmpp::parse_csv(mpmpp::data_to_csv(d), "rt.csv");
  EXPECT_EQ(back.columns, d.columns);
  EXPECT_EQ(back.missing, (std::vector<int>{0, 1}));
  EXPECT_TRUE(back.time_s == d.time_s);
  for (int k = 0; k < 3; ++k)
    for (int c = 0; c < 2; ++c)
      EXPECT_TRUE(back.values(k, c) == d.values(k, c) ||
                  (std::isnan(back.values(k, c)) && std::isnan(d.values(k, c))));
}
