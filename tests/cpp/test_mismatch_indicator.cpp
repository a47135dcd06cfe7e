#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "mpmpp/error.hpp"
#include "mpmpp/mismatch_indicator.hpp"

using mpmpp::MismatchIndicator;

// Eq. 23 written directly: negatives among the last n_T scores (earlier ones absent).
static double reference_indicator(const std::vector<double>& scores, size_t t, int n_T) {
  int neg = 0;
  for (size_t i = t + 1 > static_cast<size_t>(n_T) ? t + 1 - n_T : 0; i <= t; ++i)
    neg += scores[i] < 0;
  return static_cast<double>(neg) / n_T;
}

TEST(MismatchIndicator, MatchesDirectWindowCountOnRandomScores) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int n_T : {1, 3, 24}) {
    MismatchIndicator ind(n_T, n_T);
    std::vector<double> scores;
    for (int t = 0; t < 500; ++t) {
      double s = normal(rng) + (t / 100 % 2 ? -1.5 : 0.5);
      if (t % 37 == 0) s = std::numeric_limits<double>::quiet_NaN();
      if (t % 41 == 0) s = 0.0;
      scores.push_back(s);
      auto u = ind.push(s);
      EXPECT_DOUBLE_EQ(u.indicator, reference_indicator(scores, t, n_T)) << t;
    }
  }
}

TEST(MismatchIndicator, AlarmStartsClearsAndRestarts) {
  MismatchIndicator ind(4, 3);
  std::vector<double> scores{1, -1, -1, 1, -1, -1, 1, 1, 1, -1, -1, -1};
  std::vector<bool> alarm, started;
  for (double s : scores) {
    auto u = ind.push(s);
    alarm.push_back(u.alarm);
    started.push_back(u.started);
  }
  // negatives in last 4: 0,1,2,2,3,3,2,2,1,1,2,3
  std::vector<bool> expect_alarm{0, 0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 1};
  std::vector<bool> expect_started{0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 1};
  EXPECT_EQ(alarm, expect_alarm);
  EXPECT_EQ(started, expect_started);
}

TEST(MismatchIndicator, CheckpointRestoreContinuesIdentically) {
  MismatchIndicator a(5, 4), b(5, 4);
  std::vector<double> s{-1, -2, 3, -1, -1, -1, 2, -3, -1, -1, 1, -1};
  for (int t = 0; t < 6; ++t) a.push(s[t]);
  b.restore(a.history(), a.alarm());
  for (size_t t = 6; t < s.size(); ++t) {
    auto ua = a.push(s[t]), ub = b.push(s[t]);
    EXPECT_EQ(ua.indicator, ub.indicator);
    EXPECT_EQ(ua.alarm, ub.alarm);
    EXPECT_EQ(ua.started, ub.started);
  }
}

TEST(MismatchIndicator, RejectsBadArguments) {
  EXPECT_THROW(MismatchIndicator(0, 1), mpmpp::InputError);
  EXPECT_THROW(MismatchIndicator(4, 5), mpmpp::InputError);
  MismatchIndicator ind(3, 2);
  EXPECT_THROW(ind.restore({0, 1}, false), mpmpp::InputError);
}
