#include "mpmpp/row_quality.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <optional>

#include "mpmpp/error.hpp"
#include "text_file.hpp"

namespace mpmpp {

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::optional<double> as_number(const std::string& s) {
  try {
    std::size_t used = 0;
    const double x = std::stod(s, &used);
    if (used == s.size() && std::isfinite(x)) return x;
  } catch (const std::exception&) {
  }
  return std::nullopt;
}

}  // namespace

void mask_bad_quality(DataTable& rows, const std::string& column,
                      const std::vector<std::string>& good, const std::string& source) {
  const Eigen::Index n = rows.time_s.size();
  std::vector<bool> ok(static_cast<std::size_t>(n), false);
  const int numeric = rows.column(column);
  const auto text = std::find(rows.text_columns.begin(), rows.text_columns.end(), column);
  const std::string where = source + ": quality column \"" + detail::printable(column) + "\": ";
  if (numeric >= 0) {
    if (good.empty())
      throw InputError(
          where +
          "holds numeric codes; say which are good (--good-quality, e.g. 192 for OPC DA, "
          "0 for OPC UA, 100 for a PHD confidence)");
    std::vector<double> codes;
    for (const auto& g : good) {
      const auto x = as_number(g);
      if (!x)
        throw InputError(where + "holds numeric codes but the good code \"" + detail::printable(g) +
                         "\" is not a number");
      codes.push_back(*x);
    }
    for (Eigen::Index k = 0; k < n; ++k)
      ok[static_cast<std::size_t>(k)] =
          std::find(codes.begin(), codes.end(), rows.values(k, numeric)) != codes.end();
  } else if (text != rows.text_columns.end()) {
    const auto& cells =
        rows.text_values[static_cast<std::size_t>(text - rows.text_columns.begin())];
    std::vector<std::string> codes;
    for (const auto& g : good) codes.push_back(lower(g));
    for (Eigen::Index k = 0; k < n; ++k) {
      const std::string code = lower(cells[static_cast<std::size_t>(k)]);
      ok[static_cast<std::size_t>(k)] =
          codes.empty() ? code.rfind("good", 0) == 0
                        : std::find(codes.begin(), codes.end(), code) != codes.end();
    }
  } else {
    throw InputError(where + "no such column (columns: time, " +
                     detail::printable(detail::comma_list(rows.columns), 200) + ")");
  }
  for (Eigen::Index k = 0; k < n; ++k)
    if (!ok[static_cast<std::size_t>(k)]) {
      rows.values.row(k).setConstant(std::numeric_limits<double>::quiet_NaN());
      ++rows.repairs.bad_quality_rows;
    }
  // The status is not a process variable: it leaves the data columns.
  if (numeric >= 0) {
    const Eigen::Index keep = rows.values.cols() - 1;
    Eigen::MatrixXd values(n, keep);
    for (Eigen::Index c = 0, j = 0; c < rows.values.cols(); ++c)
      if (c != numeric) values.col(j++) = rows.values.col(c);
    rows.values = std::move(values);
    rows.columns.erase(rows.columns.begin() + numeric);
    rows.missing.erase(rows.missing.begin() + numeric);
  } else {
    const auto i = text - rows.text_columns.begin();
    rows.text_columns.erase(text);
    rows.text_values.erase(rows.text_values.begin() + i);
  }
}

}  // namespace mpmpp
