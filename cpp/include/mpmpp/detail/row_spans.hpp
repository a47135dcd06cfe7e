#pragma once
// A record of several complete stretches (no missing value or time gap inside) laid end to
// end: the estimators take it as `stretch_starts`, the rows where a new stretch begins, and
// treat every stretch as its own experiment (filters from rest, no lag across a gap).
#include <Eigen/Dense>
#include <vector>

namespace mpmpp::detail {

// Rows [begin, end) of a record: a complete stretch, or the rows of a stretch that enter a
// criterion.
struct RowSpan {
  Eigen::Index begin = 0, end = 0;
  Eigen::Index size() const { return end - begin; }
};

// spans = the complete stretches of an N-row record that starts a new stretch at each row
// of `starts` (strictly increasing, each in (0, N); empty: one stretch). InputError
// otherwise. Into the caller's vector: no allocation once it has the capacity.
void stretch_spans(Eigen::Index N, const std::vector<Eigen::Index>& starts,
                   std::vector<RowSpan>& spans);

}  // namespace mpmpp::detail
