// Historian exports on the model's sample grid: jitter, repeats, gaps, splits, quality, resampling.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "mpmpp/data_io.hpp"
#include "mpmpp/error.hpp"
#include "mpmpp/model_io.hpp"

namespace {

mpmpp::Model model(double ts = 5.0) { return mpmpp::make_model("m", ts, {"u"}, {"y"}, {}, {}); }

mpmpp::DataTable load(const std::string& csv, mpmpp::LoadOptions options = {}, double ts = 5.0) {
  return mpmpp::load_data_text(csv, "d.csv", model(ts), options);
}

std::string error_of(const std::string& csv, mpmpp::LoadOptions options = {}) {
  try {
    load(csv, options);
  } catch (const mpmpp::InputError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(TimeGrid, JitterIsSnappedAndCounted) {
  const auto d = load("time,u,y\n0,1,1\n5.001,2,2\n9.998,3,3\n15,4,4\n");
  EXPECT_EQ(d.time_s, (Eigen::VectorXd(4) << 0, 5, 10, 15).finished());
  EXPECT_EQ(d.repairs.jitter_snapped, 2);
  EXPECT_NEAR(d.repairs.max_jitter_s, 0.002, 1e-12);
  // Beyond the tolerance (a quarter sample time by default) the row is named.
  EXPECT_EQ(error_of("time,u,y\n0,1,1\n5,1,1\n12,1,1\n15,1,1\n")
                .rfind("d.csv: row 4, column time: 12 s is 2 s off", 0),
            0u);
}

TEST(TimeGrid, AJitteredFirstRowDoesNotShiftTheGrid) {
  const auto d = load("time,u,y\n1,1,1\n5,2,2\n10,3,3\n15,4,4\n20,5,5\n");
  EXPECT_DOUBLE_EQ(d.time_s[0], 0.0);
  EXPECT_DOUBLE_EQ(d.time_s[4], 20.0);
  EXPECT_EQ(d.repairs.jitter_snapped, 1);
}

TEST(TimeGrid, ShortGapsBecomeMissingRowsLongGapsSplit) {
  mpmpp::LoadOptions o;
  o.max_gap_s = 20;
  const auto d = load("time,u,y\n0,1,1\n5,1,1\n20,2,2\n25,2,2\n100,3,3\n105,3,3\n", o);
  // 5 -> 20: two rows added; 25 -> 100 (75 s > 20 s): a split marked by one missing row.
  EXPECT_EQ(d.num_samples(), 9);
  ASSERT_EQ(d.repairs.gaps.size(), 2u);
  EXPECT_FALSE(d.repairs.gaps[0].split);
  EXPECT_EQ(d.repairs.gaps[0].missing_rows, 2);
  EXPECT_TRUE(d.repairs.gaps[1].split);
  EXPECT_EQ(d.segment_starts, (std::vector<int>{7}));
  EXPECT_TRUE(std::isnan(d.values(2, 0)) && std::isnan(d.values(3, 1)) &&
              std::isnan(d.values(6, 0)));
  EXPECT_DOUBLE_EQ(d.time_s[7], 100.0);
  EXPECT_EQ(d.missing, (std::vector<int>{3, 3}));
}

TEST(TimeGrid, RepeatsAreDroppedConflictsAndDisorderNamed) {
  const auto d = load("time,u,y\n0,1,1\n5,2,2\n5,2,2\n10,3,3\n");
  EXPECT_EQ(d.num_samples(), 3);
  EXPECT_EQ(d.repairs.duplicates_dropped, 1);
  EXPECT_EQ(error_of("time,u,y\n0,1,1\n5,2,2\n5,2,3\n"),
            "d.csv: row 4, column time: 5 s repeats row 3's time with different values");
  EXPECT_EQ(error_of("time,u,y\n0,1,1\n10,2,2\n5,2,3\n")
                .rfind("d.csv: row 4, column time: 5 s is before row 3's 10 s", 0),
            0u);
  const std::string local =
      error_of("time,u,y\n2026-10-25 02:55:00,1,1\n2026-10-25 02:00:00,1,1\n");
  EXPECT_NE(local.find("daylight saving"), std::string::npos) << local;
}

TEST(TimeGrid, CalendarTimeCountsFromTheFirstSample) {
  // Daylight saving starts: the offset changes, the instants stay 5 s apart.
  const auto d = load("time,u,y\n2026-03-29T01:59:55+01:00,1,1\n2026-03-29T03:00:00+02:00,2,2\n");
  EXPECT_EQ(d.time_kind, mpmpp::TimeKind::Timestamp);
  EXPECT_DOUBLE_EQ(d.time_s[1], 5.0);
  EXPECT_EQ(mpmpp::format_time(d, 0.0), "2026-03-29T01:59:55+01:00");
  EXPECT_EQ(mpmpp::format_time(d, 5.0), "2026-03-29T03:00:00+02:00");  // as the file writes it
  const auto e = load("time,u,y\n1774745995,1,1\n1774746000.002,2,2\n1774746005,3,3\n");
  EXPECT_EQ(e.time_kind, mpmpp::TimeKind::EpochSeconds);
  EXPECT_EQ(e.time_origin, "2026-03-29T00:59:55Z");
  EXPECT_DOUBLE_EQ(e.time_s[1], 5.0);
  EXPECT_EQ(mpmpp::format_time(e, 5.0), "2026-03-29T01:00:00Z");
  EXPECT_NE(error_of("time,u,y\n1774745995000,1,1\n")
                .find("row 2, column time: \"1774745995000\" is too large"),
            std::string::npos);
}

TEST(TimeGrid, QualityColumnMasksRowsAndLeavesTheData) {
  mpmpp::LoadOptions o;
  o.quality_column = "status";
  const std::string csv =
      "time,u,y,status,tag\n0,1,1,Good,FIC101\n5,2,2,Bad,FIC101\n10,3,3,GOOD,FIC101\n15,4,4,,"
      "FIC101\n";
  const auto d = load(csv, o);
  EXPECT_EQ(d.columns, (std::vector<std::string>{"u", "y"}));
  EXPECT_EQ(d.text_columns, (std::vector<std::string>{"tag"}));
  EXPECT_EQ(d.repairs.bad_quality_rows, 2);
  EXPECT_TRUE(std::isnan(d.values(1, 0)) && std::isnan(d.values(3, 1)));
  EXPECT_DOUBLE_EQ(d.values(2, 0), 3.0);
  o.quality_column = "q";
  EXPECT_NE(error_of("time,u,y,q\n0,1,1,192\n5,1,1,0\n", o).find("say which are good"),
            std::string::npos);
  o.good_quality = {"192"};
  const auto n = load("time,u,y,q\n0,1,1,192\n5,1,1,0\n", o);
  EXPECT_EQ(n.repairs.bad_quality_rows, 1);
  EXPECT_EQ(n.columns.size(), 2u);
}

TEST(TimeGrid, TextInAModelColumnIsStillAnError) {
  EXPECT_EQ(error_of("time,u,y\n0,1,abc\n5,1,def\n"),
            "d.csv: row 2, column y: \"abc\" is not a number");
  EXPECT_EQ(error_of("time,u,y\n0,x,1\n5,1,1\n"), "d.csv: row 2, column u: \"x\" is not a number");
}

TEST(TimeGrid, ResampleAveragesBlocks) {
  mpmpp::LoadOptions o;
  o.resample_s = 5;
  std::string csv = "time,u,y\n";
  for (int k = 0; k < 12; ++k)
    csv += std::to_string(k) + "," + std::to_string(k) + "," + (k == 7 ? "" : "1") + "\n";
  const auto d = load(csv, o);
  EXPECT_EQ(d.repairs.resample_factor, 5);
  EXPECT_DOUBLE_EQ(d.repairs.raw_sample_time_s, 1.0);
  ASSERT_EQ(d.num_samples(), 3);
  EXPECT_DOUBLE_EQ(d.values(0, 0), 2.0);    // mean of 0..4
  EXPECT_TRUE(std::isnan(d.values(1, 1)));  // the block holding the missing value
  EXPECT_TRUE(std::isnan(d.values(2, 0)));  // 10, 11: a block cut short
  o.resample_s = 4;
  EXPECT_NE(error_of(csv, o).find("differs from the model's sample_time_s"), std::string::npos);
}
