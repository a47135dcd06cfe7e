#include "mpmpp/data_io.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <optional>
#include <string_view>

#include "mpmpp/error.hpp"
#include "mpmpp/row_quality.hpp"
#include "mpmpp/time_grid.hpp"
#include "text_file.hpp"

namespace mpmpp {

namespace {

constexpr double kSpacingTolerance = 1e-6;  // relative to sample_time_s

std::string quoted(const std::string& s) { return "\"" + detail::printable(s) + "\""; }
std::string row_name(std::size_t row) { return "row " + std::to_string(row); }

using detail::format_number;

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

bool is_nan_word(const std::string& s) {
  if (s.size() != 3) return false;
  return (s[0] == 'n' || s[0] == 'N') && (s[1] == 'a' || s[1] == 'A') &&
         (s[2] == 'n' || s[2] == 'N');
}

// A historian's word in place of a value ("Bad Input", "I/O Timeout"): a letter in it, and
// not an infinity, which is a number out of range.
bool is_status_word(const std::string& cell) {
  double x = 0.0;
  const char* first = cell.data() + (!cell.empty() && (cell[0] == '+' || cell[0] == '-'));
  if (std::from_chars(first, cell.data() + cell.size(), x).ec == std::errc() && std::isinf(x))
    return false;
  return std::any_of(cell.begin(), cell.end(),
                     [](unsigned char ch) { return std::isalpha(ch) != 0; });
}

// A decimal number (no hex, no words), optional leading '+'.
std::optional<double> parse_number(const std::string& cell) {
  const char* first = cell.data();
  const char* last = first + cell.size();
  if (first != last && *first == '+') ++first;
  if (first == last ||
      !(std::isdigit(static_cast<unsigned char>(*first)) || *first == '-' || *first == '.'))
    return std::nullopt;
  double x = 0.0;
  const auto r = std::from_chars(first, last, x);
  if (r.ec != std::errc() || r.ptr != last || !std::isfinite(x)) return std::nullopt;
  return x;
}

// One CSV line split into trimmed fields (RFC 4180 quoting: "a,b" and "" for ").
// Fills `fields`, reused from row to row so that reading allocates little.
void split_fields(std::string_view line, std::size_t row, const std::string& source,
                  std::vector<std::string>& fields) {
  fields.clear();
  std::size_t i = 0;
  while (true) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    std::string& field = fields.emplace_back();
    if (i < line.size() && line[i] == '"') {
      ++i;
      while (true) {
        if (i >= line.size())
          throw InputError(
              source + ": " + row_name(row) +
              ": unterminated quoted field (line breaks inside quotes are not supported)");
        if (line[i] == '"') {
          if (i + 1 < line.size() && line[i + 1] == '"') {
            field += '"';
            i += 2;
            continue;
          }
          ++i;
          break;
        }
        field += line[i++];
      }
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
      if (i < line.size() && line[i] != ',')
        throw InputError(source + ": " + row_name(row) + ": text after a closing quote in field " +
                         std::to_string(fields.size()));
    } else {
      const std::size_t end = std::min(line.find(',', i), line.size());
      field = trim(line.substr(i, end - i));
      i = end;
    }
    if (i >= line.size()) break;
    ++i;  // the comma
  }
}

// Lines without their "\r\n" / "\n", trailing blank lines dropped; views into `text`.
std::vector<std::string_view> split_lines(std::string_view text) {
  std::vector<std::string_view> lines;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t end = std::min(text.find('\n', start), text.size());
    std::string_view line = text.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
    start = end + 1;
  }
  while (!lines.empty() && trim(lines.back()).empty()) lines.pop_back();
  return lines;
}

// ---- ISO-8601 timestamps -------------------------------------------------------

struct Timestamp {
  std::int64_t seconds;  // whole seconds since 1970-01-01 (UTC if an offset was given)
  double fraction;       // [0, 1)
  bool has_offset;
  int offset_s;  // the UTC offset written (0 without one)
};

// Days since 1970-01-01 of a proleptic Gregorian date (the civil-from-days
// relation: years counted from March so that the leap day is last).
std::int64_t days_from_civil(int y, int m, int d) {
  y -= m <= 2;
  const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
  const int yoe = static_cast<int>(y - era * 400);
  const int doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const int doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + doe - 719468;
}

// The inverse: (year, month, day) of a day count since 1970-01-01.
void civil_from_days(std::int64_t z, int& y, int& m, int& d) {
  z += 719468;
  const std::int64_t era = (z >= 0 ? z : z - 146096) / 146097;
  const int doe = static_cast<int>(z - era * 146097);
  const int yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
  const int doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
  const int mp = (5 * doy + 2) / 153;
  d = doy - (153 * mp + 2) / 5 + 1;
  m = mp + (mp < 10 ? 3 : -9);
  y = static_cast<int>(yoe + era * 400) + (m <= 2);
}

// "YYYY-MM-DDThh:mm:ss[.fff]" of Unix time `t` shifted by `offset_s`, then the offset.
std::string iso_timestamp(double t, int offset_s, const char* zone) {
  const double local = t + offset_s;
  const double whole = std::floor(local);
  long long ms = std::llround((local - whole) * 1000.0);
  std::int64_t secs = static_cast<std::int64_t>(whole);
  if (ms == 1000) {
    ms = 0;
    ++secs;
  }
  const std::int64_t days = (secs >= 0 ? secs : secs - 86399) / 86400;
  const int sod = static_cast<int>(secs - days * 86400);
  int y, m, d;
  civil_from_days(days, y, m, d);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%04d-%02d-%02dT%02d:%02d:%02d", y, m, d, sod / 3600,
                sod / 60 % 60, sod % 60);
  std::string out = buf;
  if (ms) {
    std::snprintf(buf, sizeof buf, ".%03lld", ms);
    out += buf;
  }
  if (zone) return out + zone;
  std::snprintf(buf, sizeof buf, "%c%02d:%02d", offset_s < 0 ? '-' : '+', std::abs(offset_s) / 3600,
                std::abs(offset_s) / 60 % 60);
  return out + buf;
}

int days_in_month(int y, int m) {
  static const int days[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  const bool leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
  return m == 2 && leap ? 29 : days[m - 1];
}

// YYYY-MM-DD[(T| )hh:mm[:ss[.f+]]][Z|(+|-)hh[:mm]]
std::optional<Timestamp> parse_timestamp(const std::string& s) {
  std::size_t i = 0;
  auto digits = [&](int n, int& out) {
    if (i + n > s.size()) return false;
    out = 0;
    for (int k = 0; k < n; ++k) {
      const char c = s[i + k];
      if (c < '0' || c > '9') return false;
      out = out * 10 + (c - '0');
    }
    i += n;
    return true;
  };
  auto literal = [&](char c) {
    if (i < s.size() && s[i] == c) {
      ++i;
      return true;
    }
    return false;
  };
  int year, month, day, hour = 0, minute = 0, second = 0;
  double fraction = 0.0;
  if (!digits(4, year) || !literal('-') || !digits(2, month) || !literal('-') || !digits(2, day))
    return std::nullopt;
  if (month < 1 || month > 12 || day < 1 || day > days_in_month(year, month)) return std::nullopt;
  if (literal('T') || literal(' ')) {
    if (!digits(2, hour) || !literal(':') || !digits(2, minute)) return std::nullopt;
    if (literal(':')) {
      if (!digits(2, second)) return std::nullopt;
      if (literal('.') || literal(',')) {
        double scale = 0.1;
        const std::size_t start = i;
        while (i < s.size() && s[i] >= '0' && s[i] <= '9') {
          fraction += (s[i++] - '0') * scale;
          scale /= 10;
        }
        if (i == start) return std::nullopt;
      }
    }
    if (hour > 23 || minute > 59 || second > 59) return std::nullopt;
  }
  std::int64_t offset_s = 0;
  bool has_offset = false;
  if (literal('Z')) {
    has_offset = true;
  } else if (i < s.size() && (s[i] == '+' || s[i] == '-')) {
    const int sign = s[i++] == '-' ? -1 : 1;
    int oh, om = 0;
    if (!digits(2, oh)) return std::nullopt;
    if (literal(':')) {
      if (!digits(2, om)) return std::nullopt;
    } else if (i < s.size()) {
      if (!digits(2, om)) return std::nullopt;
    }
    if (oh > 23 || om > 59) return std::nullopt;
    offset_s = sign * (oh * 3600 + om * 60);
    has_offset = true;
  }
  if (i != s.size()) return std::nullopt;
  const std::int64_t secs =
      days_from_civil(year, month, day) * 86400 + hour * 3600 + minute * 60 + second - offset_s;
  return Timestamp{secs, fraction, has_offset, static_cast<int>(offset_s)};
}

// ---- the time column --------------------------------------------------------------

// Reads the time column into d.time_s: numbers of seconds, or calendar time (epoch
// seconds, timestamps) turned into seconds since the first row; which of them is
// decided by the first row.
void read_time(const std::vector<std::string>& cells, const std::string& source, DataTable& d) {
  const std::size_t n = cells.size();
  Eigen::VectorXd t(static_cast<Eigen::Index>(n));
  auto where = [&](std::size_t k) { return source + ": " + row_name(k + 2) + ", column time: "; };
  for (std::size_t k = 0; k < n; ++k)
    if (cells[k].empty() || is_nan_word(cells[k])) throw InputError(where(k) + "time is missing");
  const bool numeric = parse_number(cells[0]).has_value();
  if (numeric) {
    for (std::size_t k = 0; k < n; ++k) {
      const auto x = parse_number(cells[k]);
      if (!x)
        throw InputError(where(k) + quoted(cells[k]) + " is not a number of seconds (row 2 is)");
      t[static_cast<Eigen::Index>(k)] = *x;
    }
    // Past the year 5000 in seconds: an export in epoch milliseconds or microseconds.
    if (t[0] >= 1e11)
      throw InputError(where(0) + quoted(cells[0]) +
                       " is too large for Unix epoch seconds (milliseconds? "
                       "write seconds or ISO-8601 timestamps)");
    if (t[0] >= kEpochThresholdS) {
      d.time_kind = TimeKind::EpochSeconds;
      d.origin_epoch_s = t[0];
      d.time_origin = iso_timestamp(t[0], 0, "Z");
      d.utc_offsets = {{0.0, 0}};
      t.array() -= d.origin_epoch_s;
    }
    d.time_s = std::move(t);
    return;
  }
  const auto first = parse_timestamp(cells[0]);
  if (!first)
    throw InputError(where(0) + quoted(cells[0]) + " is neither seconds nor an ISO-8601 timestamp");
  d.time_origin = cells[0];
  d.time_kind = first->has_offset ? TimeKind::Timestamp : TimeKind::LocalTimestamp;
  d.origin_epoch_s = static_cast<double>(first->seconds) + first->fraction;
  d.utc_offsets = {{0.0, first->offset_s}};
  for (std::size_t k = 0; k < n; ++k) {
    const auto ts = parse_timestamp(cells[k]);
    if (!ts)
      throw InputError(where(k) + quoted(cells[k]) + " is not an ISO-8601 timestamp (row 2 is)");
    if (ts->has_offset != first->has_offset)
      throw InputError(where(k) + quoted(cells[k]) +
                       (first->has_offset ? " has no UTC offset but row 2 has one"
                                          : " has a UTC offset but row 2 has none"));
    // Whole seconds subtracted as integers first, so the result keeps sub-microsecond precision.
    t[static_cast<Eigen::Index>(k)] =
        static_cast<double>(ts->seconds - first->seconds) + (ts->fraction - first->fraction);
    if (ts->offset_s != d.utc_offsets.back().second)
      d.utc_offsets.emplace_back(t[static_cast<Eigen::Index>(k)], ts->offset_s);
  }
  d.time_s = std::move(t);
}

void check_increasing(const Eigen::VectorXd& t, const std::string& source) {
  for (Eigen::Index k = 1; k < t.size(); ++k)
    if (!(t[k] > t[k - 1]))
      throw InputError(source + ": " + row_name(static_cast<std::size_t>(k) + 2) +
                       ", column time: " + format_number(t[k]) +
                       " s is not after the previous row's " + format_number(t[k - 1]) +
                       " s (time must be strictly increasing)");
}

void check_column_names(const std::vector<std::string>& names, const std::string& where) {
  std::map<std::string, std::size_t> seen;
  for (std::size_t c = 0; c < names.size(); ++c) {
    if (names[c].empty())
      throw InputError(where + "column " + std::to_string(c + 1) + " has an empty name");
    if (names[c].find_first_of("\r\n") != std::string::npos)
      throw InputError(where + "column " + std::to_string(c + 1) + " has a line break in its name");
    const auto [it, fresh] = seen.emplace(names[c], c);
    if (!fresh)
      throw InputError(where + "duplicate column " + quoted(names[c]) + " (columns " +
                       std::to_string(it->second + 1) + " and " + std::to_string(c + 1) + ")");
  }
}

// A CSV field, quoted when it would otherwise not read back as the same text.
std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"") == std::string::npos && s == trim(s)) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

}  // namespace

int DataTable::column(const std::string& name) const {
  for (std::size_t c = 0; c < columns.size(); ++c)
    if (columns[c] == name) return static_cast<int>(c);
  return -1;
}

namespace {

// What every table must satisfy to be written and read back.
void check_parts(const Eigen::VectorXd& time_s, const std::vector<std::string>& columns,
                 const Eigen::MatrixXd& values) {
  if (values.rows() != time_s.size() || values.cols() != static_cast<Eigen::Index>(columns.size()))
    throw InputError("values: shape " + std::to_string(values.rows()) + "x" +
                     std::to_string(values.cols()) + ", expected " + std::to_string(time_s.size()) +
                     " samples x " + std::to_string(columns.size()) + " columns");
  std::vector<std::string> all{"time"};
  all.insert(all.end(), columns.begin(), columns.end());
  check_column_names(all, "");
  if (!time_s.allFinite()) throw InputError("time: must be finite");
  check_increasing(time_s, "time");
  for (Eigen::Index c = 0; c < values.cols(); ++c)
    for (Eigen::Index k = 0; k < values.rows(); ++k)
      if (std::isinf(values(k, c)))
        throw InputError("column " + columns[c] + ": infinite value at sample " +
                         std::to_string(k));
      else if (std::abs(values(k, c)) >= kLargestValue)  // the reader would refuse the file
        throw InputError("column " + columns[c] + ": value " + format_number(values(k, c)) +
                         " at sample " + std::to_string(k) +
                         " is too large to compute with (magnitude 1e100 or more)");
}

}  // namespace

DataTable make_data_table(Eigen::VectorXd time_s, std::vector<std::string> columns,
                          Eigen::MatrixXd values) {
  check_parts(time_s, columns, values);
  DataTable d;
  d.missing.resize(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c)
    d.missing[c] =
        static_cast<int>(values.col(static_cast<Eigen::Index>(c)).array().isNaN().count());
  d.time_s = std::move(time_s);
  d.columns = std::move(columns);
  d.values = std::move(values);
  return d;
}

namespace {

DataTable parse_csv_text(const std::string& text, const std::string& source) {
  const std::string where = source + ": ";
  if (text.find_first_not_of(" \t\r\n") == std::string::npos)
    throw InputError(where + "file is empty");
  if (text.find('\0') != std::string::npos)
    throw InputError(where + "not a CSV file (binary content)");
  std::vector<std::string_view> lines = split_lines(text);
  if (lines[0].substr(0, 3) == "\xEF\xBB\xBF") lines[0].remove_prefix(3);  // UTF-8 byte order mark

  std::vector<std::string> header;
  split_fields(lines[0], 1, source, header);
  std::size_t time_col = header.size();
  for (std::size_t c = 0; c < header.size(); ++c)
    if (header[c] == "time") time_col = c;
  if (time_col == header.size()) {
    if (header.size() == 1) {
      // a spreadsheet export in a locale with decimal commas separates its fields by ';' or tabs
      const char* other = header[0].find(';') != std::string::npos    ? "';'"
                          : header[0].find('\t') != std::string::npos ? "tabs"
                                                                      : nullptr;
      throw InputError(
          where + "not a CSV file with a header row: row 1 is " + quoted(header[0]) +
          " (expected comma-separated column names including \"time\"" +
          (other ? std::string("; this row is separated by ") + other +
                       ": save the file with ',' between fields and '.' as the decimal point"
                 : std::string()) +
          ")");
    }
    throw InputError(where + "row 1: no \"time\" column (columns: " +
                     detail::printable(detail::comma_list(header), 200) + ")");
  }
  check_column_names(header, where + "row 1: ");
  if (lines.size() < 2) throw InputError(where + "no data rows after the header");

  const std::size_t n = lines.size() - 1;
  std::vector<std::string> time_cells(n);
  DataTable d;
  for (std::size_t c = 0; c < header.size(); ++c)
    if (c != time_col) d.columns.push_back(header[c]);
  const std::size_t width = d.columns.size();
  d.values.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(width));
  d.missing.assign(width, 0);
  // A column is text while it holds no number: its cells are kept until a number turns up.
  // In a column that has numbers, a cell with a letter in it is a status word a historian
  // writes in place of a value ("Bad Input", "I/O Timeout", "Shutdown"): a missing value,
  // counted in repairs.status_words, as long as the column has more numbers than such words
  // (else it is not numeric, and its first word is the error). A cell that is no number and
  // has no letter ("12,5", "1.2.3"), or is infinite, is a number written wrongly: an error,
  // never read as missing.
  struct CellCounts {
    std::size_t numbers = 0, words = 0, first_word_row = 0, first_malformed_row = 0;
    std::string first_word, first_malformed;
  };
  std::vector<CellCounts> counts(width);
  std::vector<std::vector<std::string>> text_cells(width);
  auto cell_error = [&](std::size_t j, std::size_t row, const std::string& cell, const char* what) {
    return InputError(where + row_name(row) + ", column " + detail::printable(d.columns[j]) + ": " +
                      quoted(cell) + what);
  };
  auto not_a_number = [&](std::size_t j, std::size_t row, const std::string& cell) {
    return cell_error(j, row, cell, " is not a number");
  };
  std::vector<std::string> fields;
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t row = k + 2;
    if (trim(lines[k + 1]).empty()) throw InputError(where + row_name(row) + ": empty line");
    split_fields(lines[k + 1], row, source, fields);
    if (fields.size() != header.size())
      throw InputError(where + row_name(row) + ": " + std::to_string(fields.size()) +
                       " fields, the header has " + std::to_string(header.size()));
    std::size_t j = 0;
    for (std::size_t c = 0; c < fields.size(); ++c) {
      if (c == time_col) {
        time_cells[k] = fields[c];
        continue;
      }
      double x = std::numeric_limits<double>::quiet_NaN();
      CellCounts& count = counts[j];
      const std::string& cell = fields[c];
      const bool empty = cell.empty() || is_nan_word(cell);
      if (empty) {
        ++d.missing[j];
      } else if (const auto v = parse_number(cell)) {
        if (std::abs(*v) >= kLargestValue)
          throw cell_error(j, row, cell,
                           " is too large to compute with (magnitude 1e100 or more: its squares "
                           "overflow); check the column's units");
        ++count.numbers;
        x = *v;
      } else if (is_status_word(cell)) {
        if (!count.words++) {
          count.first_word_row = row;
          count.first_word = cell;
        }
      } else if (!count.first_malformed_row) {
        count.first_malformed_row = row;
        count.first_malformed = cell;
      }
      if (!count.numbers) {
        text_cells[j].push_back(cell);  // one per row while the column has no number
      } else if (!text_cells[j].empty()) {
        text_cells[j] = {};  // a numeric column: its cells are not needed
      }
      d.values(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(j++)) = x;
    }
  }
  read_time(time_cells, source, d);
  // Text columns leave the numeric table; their cells are kept for the quality column and
  // for naming them in errors.
  std::vector<Eigen::Index> numeric;
  for (std::size_t j = 0; j < width; ++j) {
    const CellCounts& count = counts[j];
    if (count.numbers) {
      if (count.first_malformed_row)
        throw not_a_number(j, count.first_malformed_row, count.first_malformed);
      if (count.words >= count.numbers)
        throw not_a_number(j, count.first_word_row, count.first_word);
      if (count.words) {
        d.missing[j] += static_cast<int>(count.words);
        d.repairs.status_words.push_back(
            {d.columns[j], static_cast<int>(count.words), count.first_word});
      }
      numeric.push_back(static_cast<Eigen::Index>(j));
      continue;
    }
    if (!count.words && !count.first_malformed_row) {  // empty cells only: a numeric column
      numeric.push_back(static_cast<Eigen::Index>(j));
      continue;
    }
    d.text_columns.push_back(d.columns[j]);
    d.text_values.push_back(std::move(text_cells[j]));
  }
  if (numeric.size() < width) {
    std::vector<std::string> columns;
    std::vector<int> missing;
    Eigen::MatrixXd values(d.values.rows(), static_cast<Eigen::Index>(numeric.size()));
    for (std::size_t i = 0; i < numeric.size(); ++i) {
      columns.push_back(d.columns[static_cast<std::size_t>(numeric[i])]);
      missing.push_back(d.missing[static_cast<std::size_t>(numeric[i])]);
      values.col(static_cast<Eigen::Index>(i)) = d.values.col(numeric[i]);
    }
    d.columns = std::move(columns);
    d.missing = std::move(missing);
    d.values = std::move(values);
  }
  return d;
}

// The first cell of a text column that is not empty, for naming it in an error.
std::string first_text_cell(const DataTable& d, std::size_t i, std::size_t& row) {
  row = 2;
  if (i >= d.text_values.size()) return {};  // a grid table keeps the names only
  const auto& cells = d.text_values[i];
  for (std::size_t k = 0; k < cells.size(); ++k)
    if (!cells[k].empty() && !is_nan_word(cells[k])) {
      row = k + 2;
      return cells[k];
    }
  return {};
}

// The model's inputs and outputs are numeric columns (text in them is named as on reading).
void check_columns(const DataTable& data, const Model& model, const std::string& source) {
  auto require = [&](const std::vector<std::string>& names, const char* kind) {
    for (const auto& name : names) {
      if (data.column(name) >= 0) continue;
      const auto text = std::find(data.text_columns.begin(), data.text_columns.end(), name);
      if (text != data.text_columns.end()) {
        std::size_t row = 0;
        const std::string cell =
            first_text_cell(data, static_cast<std::size_t>(text - data.text_columns.begin()), row);
        throw InputError(source + ": " + row_name(row) + ", column " + detail::printable(name) +
                         ": " + quoted(cell) + " is not a number");
      }
      throw InputError(source + ": column " + quoted(name) + " (model " + kind +
                       ") is missing (columns: time" + (data.columns.empty() ? "" : ", ") +
                       detail::printable(detail::comma_list(data.columns), 200) + ")");
    }
  };
  require(model.inputs, "input");
  require(model.outputs, "output");
}

// Within each segment, the time step is the model's sample time.
void check_spacing(const DataTable& data, const Model& model, const std::string& source) {
  const double ts = model.sample_time_s;
  auto next_segment = data.segment_starts.begin();
  for (Eigen::Index k = 1; k < data.time_s.size(); ++k) {
    // A split is a missing row between two segments: the steps around it are free.
    if (next_segment != data.segment_starts.end() && k + 1 >= *next_segment) {
      if (k == *next_segment) ++next_segment;
      continue;
    }
    const double step = data.time_s[k] - data.time_s[k - 1];
    if (std::abs(step - ts) > kSpacingTolerance * ts)
      throw InputError(source + ": " + row_name(static_cast<std::size_t>(k) + 2) +
                       ", column time: time step " + format_number(step) +
                       " s from the previous row, expected the model's sample_time_s = " +
                       format_number(ts) + " s");
  }
}

void check_against_model(const DataTable& data, const Model& model, const std::string& source) {
  check_columns(data, model, source);
  check_spacing(data, model, source);
}

// Runs `check` with every InputError it throws made one line.
template <class Check>
auto one_line_errors(Check check) -> decltype(check()) {
  try {
    return check();
  } catch (const InputError& e) {
    throw InputError(detail::one_line(e.what()));
  }
}

}  // namespace

DataTable parse_csv_rows(const std::string& text, const std::string& source) {
  return one_line_errors([&] { return parse_csv_text(text, source); });
}

DataTable parse_csv(const std::string& text, const std::string& source) {
  return one_line_errors([&] {
    DataTable d = parse_csv_text(text, source);
    check_increasing(d.time_s, source);
    return d;
  });
}

DataTable read_csv(const std::string& path) {
  return parse_csv(detail::read_text_file(path), path);
}

DataTable read_csv_rows(const std::string& path) {
  return parse_csv_rows(detail::read_text_file(path), path);
}

void validate_data(const DataTable& data, const Model& model, const std::string& source) {
  one_line_errors([&] { check_against_model(data, model, source); });
}

namespace {

DataTable repaired(DataTable rows, const std::string& source, const Model& model,
                   const LoadOptions& options) {
  const double ts = model.sample_time_s;
  if (!options.quality_column.empty())
    mask_bad_quality(rows, options.quality_column, options.good_quality, source);
  rows.repairs.text_columns = rows.text_columns;
  GridOptions grid{ts, options.max_gap_s < 0 ? 10.0 * ts : options.max_gap_s,
                   options.jitter_fraction};
  if (!(options.jitter_fraction >= 0 && options.jitter_fraction < 0.5))
    throw InputError(source + ": the jitter tolerance must be in [0, 0.5) sample times, got " +
                     format_number(options.jitter_fraction));
  if (options.resample_s <= 0) return regularize(rows, grid, source);
  if (std::abs(options.resample_s - ts) > kSpacingTolerance * ts)
    throw InputError(source + ": --resample " + format_number(options.resample_s) +
                     " s differs from the model's sample_time_s = " + format_number(ts) + " s");
  const double raw = median_step(rows);
  const long long factor = raw > 0 ? std::llround(ts / raw) : 0;
  if (factor < 1 ||
      std::abs(ts - static_cast<double>(factor) * raw) > options.jitter_fraction * raw)
    throw InputError(
        source + ": the file's sample time " + format_number(raw) +
        " s (median step) does not divide the model's sample_time_s = " + format_number(ts) + " s");
  const double raw_ts = ts / static_cast<double>(factor);
  grid.sample_time_s = raw_ts;
  grid.max_gap_s = std::max(grid.max_gap_s, raw_ts);
  DataTable out = block_average(regularize(rows, grid, source), static_cast<int>(factor));
  out.repairs.raw_sample_time_s = raw_ts;
  return out;
}

}  // namespace

DataTable load_data_text(const std::string& text, const std::string& source, const Model& model,
                         const LoadOptions& options) {
  return one_line_errors([&] {
    DataTable rows = parse_csv_text(text, source);
    check_columns(rows, model, source);
    DataTable d = repaired(std::move(rows), source, model, options);
    check_spacing(d, model, source);
    return d;
  });
}

DataTable load_data(const std::string& path, const Model& model, const LoadOptions& options) {
  return load_data_text(detail::read_text_file(path), path, model, options);
}

int utc_offset_at(const DataTable& data, double time_s) {
  if (data.utc_offsets.empty()) return 0;
  int offset = data.utc_offsets.front().second;  // before the first row: the first row's
  for (const auto& [from, value] : data.utc_offsets)
    if (from <= time_s) offset = value;
  return offset;
}

std::string format_time(const DataTable& data, double time_s) {
  switch (data.time_kind) {
    case TimeKind::Seconds:
      return format_number(time_s) + " s";
    case TimeKind::EpochSeconds:
      return iso_timestamp(data.origin_epoch_s + time_s, 0, "Z");
    case TimeKind::LocalTimestamp:
      return iso_timestamp(data.origin_epoch_s + time_s, 0, "");
    case TimeKind::Timestamp:
      break;
  }
  const int offset = utc_offset_at(data, time_s);
  return iso_timestamp(data.origin_epoch_s + time_s, offset, offset ? nullptr : "Z");
}

std::string data_to_csv(const DataTable& d) {
  check_parts(d.time_s, d.columns, d.values);  // every file written reads back
  std::string out = "time";
  for (const auto& c : d.columns) out += "," + csv_field(c);
  out += "\n";
  for (Eigen::Index k = 0; k < d.time_s.size(); ++k) {
    out += format_number(d.time_s[k]);
    for (Eigen::Index c = 0; c < d.values.cols(); ++c) {
      out += ",";
      if (!std::isnan(d.values(k, c))) out += format_number(d.values(k, c));
    }
    out += "\n";
  }
  return out;
}

void write_csv(const DataTable& data, const std::string& path) {
  std::string text;
  try {
    text = data_to_csv(data);
  } catch (const InputError& e) {
    throw InputError(path + ": " + e.what());
  }
  detail::write_file_atomic(path, text);
}

}  // namespace mpmpp
