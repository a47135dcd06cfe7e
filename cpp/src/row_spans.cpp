#include "mpmpp/detail/row_spans.hpp"

#include <string>

#include "mpmpp/error.hpp"

namespace mpmpp::detail {

void stretch_spans(Eigen::Index N, const std::vector<Eigen::Index>& starts,
                   std::vector<RowSpan>& spans) {
  spans.clear();
  Eigen::Index begin = 0;
  for (const Eigen::Index s : starts) {
    if (s <= begin || s >= N)
      throw InputError("stretch_starts must be strictly increasing rows in (0, " +
                       std::to_string(N) + "), got " + std::to_string(s) + " after " +
                       std::to_string(begin));
    spans.push_back({begin, s});
    begin = s;
  }
  spans.push_back({begin, N});
}

}  // namespace mpmpp::detail
