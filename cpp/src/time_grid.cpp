#include "mpmpp/time_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "mpmpp/error.hpp"
#include "text_file.hpp"

namespace mpmpp {

namespace {

using detail::format_number;

std::string row_name(Eigen::Index k) { return "row " + std::to_string(k + 2); }

bool same_values(const Eigen::MatrixXd& v, Eigen::Index a, Eigen::Index b) {
  for (Eigen::Index c = 0; c < v.cols(); ++c) {
    const double x = v(a, c), y = v(b, c);
    if (!(x == y || (std::isnan(x) && std::isnan(y)))) return false;
  }
  return true;
}

// Rows kept after dropping exact repeats; rows out of order are an error (a
// historian does not write them; naive local time does, once a year).
std::vector<Eigen::Index> ordered_rows(const DataTable& rows, DataRepairs& repairs,
                                       const std::string& source) {
  std::vector<Eigen::Index> kept{0};
  const Eigen::VectorXd& t = rows.time_s;
  for (Eigen::Index k = 1; k < t.size(); ++k) {
    const Eigen::Index prev = kept.back();
    if (t[k] > t[prev]) {
      kept.push_back(k);
      continue;
    }
    const std::string where =
        source + ": " + row_name(k) + ", column time: " + format_time(rows, t[k]);
    if (t[k] == t[prev]) {
      if (!same_values(rows.values, k, prev))
        throw InputError(where + " repeats " + row_name(prev) + "'s time with different values");
      ++repairs.duplicates_dropped;
      continue;
    }
    std::string hint;
    if (rows.time_kind == TimeKind::LocalTimestamp)
      hint =
          "; local times without a UTC offset repeat an hour when daylight saving time ends: "
          "export with offsets or in UTC";
    throw InputError(where + " is before " + row_name(prev) + "'s " + format_time(rows, t[prev]) +
                     " (rows must be in time order" + hint + ")");
  }
  return kept;
}

// How far a segment's rows sit off a grid anchored at its first row, as the median
// offset: one jittered first row does not shift the whole grid.
double grid_phase(const Eigen::VectorXd& t, const std::vector<Eigen::Index>& seg, double ts) {
  std::vector<double> offsets;
  offsets.reserve(seg.size());
  for (const Eigen::Index k : seg) {
    const double x = t[k] - t[seg.front()];
    offsets.push_back(x - std::round(x / ts) * ts);
  }
  auto mid = offsets.begin() + static_cast<std::ptrdiff_t>(offsets.size() / 2);
  std::nth_element(offsets.begin(), mid, offsets.end());
  return *mid;
}

}  // namespace

double median_step(const DataTable& rows) {
  std::vector<double> steps;
  for (Eigen::Index k = 1; k < rows.time_s.size(); ++k)
    if (rows.time_s[k] > rows.time_s[k - 1]) steps.push_back(rows.time_s[k] - rows.time_s[k - 1]);
  if (steps.empty()) return 0.0;
  auto mid = steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2);
  std::nth_element(steps.begin(), mid, steps.end());
  return *mid;
}

DataTable regularize(const DataTable& rows, const GridOptions& options, const std::string& source) {
  const double ts = options.sample_time_s;
  const double tolerance = options.jitter_fraction * ts;
  DataTable out;
  out.repairs = rows.repairs;
  DataRepairs& repairs = out.repairs;
  const std::vector<Eigen::Index> kept = ordered_rows(rows, repairs, source);
  const Eigen::VectorXd& t = rows.time_s;
  // A file sampled slower than the model would put a missing row between every two samples:
  // a silent half-empty record. Gaps are occasional; a slower rate is a mismatch to fix.
  if (const double step = median_step(rows); step >= 1.5 * ts)
    throw InputError(
        source + ": column time: samples are " + format_number(step) +
        " s apart (median), slower than the model's sample time of " + format_number(ts) +
        " s; use a model with that sample time or export the data at " + format_number(ts) + " s");

  // Segments: a step longer than max_gap_s (and than a missed sample) starts a new one.
  std::vector<std::vector<Eigen::Index>> segments{{kept.front()}};
  for (std::size_t j = 1; j < kept.size(); ++j) {
    const double step = t[kept[j]] - t[kept[j - 1]];
    if (step > options.max_gap_s && step >= 1.5 * ts) segments.emplace_back();
    segments.back().push_back(kept[j]);
  }

  // Grid positions per row: (segment anchor, sample index within the segment).
  std::vector<double> times;
  std::vector<Eigen::Index> source_row;  // -1 for an added missing row
  double first_anchor = 0.0;
  for (std::size_t s = 0; s < segments.size(); ++s) {
    const auto& seg = segments[s];
    const double anchor = t[seg.front()] + grid_phase(t, seg, ts);
    if (s == 0) first_anchor = anchor;
    if (s > 0) {
      repairs.gaps.push_back({t[segments[s - 1].back()], t[seg.front()], 1, true});
      // The missing row that marks the break: on the old grid when there is room.
      times.push_back(std::min(times.back() + ts, 0.5 * (times.back() + anchor)));
      source_row.push_back(-1);
      out.segment_starts.push_back(static_cast<int>(times.size()));
    }
    long long previous = -1;
    for (const Eigen::Index k : seg) {
      const long long index = std::llround((t[k] - anchor) / ts);
      const double offset = t[k] - (anchor + static_cast<double>(index) * ts);
      if (std::abs(offset) > tolerance)
        throw InputError(source + ": " + row_name(k) + ", column time: " + format_time(rows, t[k]) +
                         " is " + format_number(std::abs(offset)) + " s off the " +
                         format_number(ts) + " s sample grid, more than the jitter tolerance of " +
                         format_number(tolerance) +
                         " s (is the file sampled at another rate? see --resample)");
      if (std::abs(offset) > 1e-6 * ts) {
        ++repairs.jitter_snapped;
        repairs.max_jitter_s = std::max(repairs.max_jitter_s, std::abs(offset));
      }
      if (index == previous) {
        if (!same_values(rows.values, k, source_row.back()))
          throw InputError(source + ": " + row_name(k) +
                           ", column time: " + format_time(rows, t[k]) +
                           " falls on the same sample as " + row_name(source_row.back()) +
                           " with different values (the file is sampled faster than " +
                           format_number(ts) + " s: see --resample)");
        ++repairs.duplicates_dropped;
        continue;
      }
      if (previous >= 0 && index > previous + 1) {
        const long long added = index - previous - 1;
        repairs.gaps.push_back({t[source_row.back()], t[k], static_cast<int>(added), false});
        for (long long m = previous + 1; m < index; ++m) {
          times.push_back(anchor + static_cast<double>(m) * ts);
          source_row.push_back(-1);
        }
      }
      times.push_back(anchor + static_cast<double>(index) * ts);
      source_row.push_back(k);
      previous = index;
    }
  }

  // Calendar time counts from the first grid row; plain seconds stay as written.
  const bool calendar = rows.time_kind != TimeKind::Seconds;
  out.time_kind = rows.time_kind;
  out.time_origin = rows.time_origin;
  out.utc_offsets = rows.utc_offsets;
  for (auto& change : out.utc_offsets) change.first -= calendar ? first_anchor : 0.0;
  out.origin_epoch_s = rows.origin_epoch_s + (calendar ? first_anchor : 0.0);
  const Eigen::Index n = static_cast<Eigen::Index>(times.size());
  out.time_s.resize(n);
  out.columns = rows.columns;
  out.values.resize(n, rows.values.cols());
  for (Eigen::Index r = 0; r < n; ++r) {
    out.time_s[r] = calendar ? times[static_cast<std::size_t>(r)] - first_anchor
                             : times[static_cast<std::size_t>(r)];
    const Eigen::Index k = source_row[static_cast<std::size_t>(r)];
    if (k >= 0)
      out.values.row(r) = rows.values.row(k);
    else
      out.values.row(r).setConstant(std::numeric_limits<double>::quiet_NaN());
  }
  out.missing.resize(out.columns.size());
  for (std::size_t c = 0; c < out.columns.size(); ++c)
    out.missing[c] =
        static_cast<int>(out.values.col(static_cast<Eigen::Index>(c)).array().isNaN().count());
  out.text_columns = rows.text_columns;
  out.text_values.clear();  // text cells belong to the file's rows, not to the grid
  return out;
}

DataTable block_average(const DataTable& grid, int factor) {
  DataTable out = grid;
  if (factor <= 1) return out;
  std::vector<Eigen::Index> bounds;  // segment [start, end) rows
  bounds.push_back(0);
  for (const int s : grid.segment_starts) bounds.push_back(s);
  bounds.push_back(grid.time_s.size());
  std::vector<double> times;
  std::vector<Eigen::VectorXd> rows;
  out.segment_starts.clear();
  const Eigen::Index cols = grid.values.cols();
  for (std::size_t s = 0; s + 1 < bounds.size(); ++s) {
    if (s > 0) out.segment_starts.push_back(static_cast<int>(times.size()));
    for (Eigen::Index a = bounds[s]; a < bounds[s + 1]; a += factor) {
      const Eigen::Index len = std::min<Eigen::Index>(factor, bounds[s + 1] - a);
      Eigen::VectorXd mean = grid.values.middleRows(a, len).colwise().mean().transpose();
      if (len < factor) mean.setConstant(std::numeric_limits<double>::quiet_NaN());
      times.push_back(grid.time_s[a]);  // NaN in a block propagates through the mean
      rows.push_back(std::move(mean));
    }
  }
  const Eigen::Index n = static_cast<Eigen::Index>(times.size());
  out.time_s = Eigen::Map<const Eigen::VectorXd>(times.data(), n);
  out.values.resize(n, cols);
  for (Eigen::Index r = 0; r < n; ++r)
    out.values.row(r) = rows[static_cast<std::size_t>(r)].transpose();
  for (std::size_t c = 0; c < out.columns.size(); ++c)
    out.missing[c] =
        static_cast<int>(out.values.col(static_cast<Eigen::Index>(c)).array().isNaN().count());
  out.repairs.resample_factor = factor;
  return out;
}

}  // namespace mpmpp
