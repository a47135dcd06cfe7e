#pragma once
// The regular sample grid the model assumes, made from a data file's rows as a
// historian exports them: timestamps a little off the grid are snapped onto it
// (and counted), repeated rows dropped, short gaps filled with missing rows, and
// long gaps split the record into segments. Nothing is interpolated: every
// added row is missing, and each split is marked by one missing row so that every
// filter downstream restarts there as it does at any missing value.
#include <string>

#include "mpmpp/data_io.hpp"

namespace mpmpp {

struct GridOptions {
  double sample_time_s = 1.0;
  double max_gap_s = 10.0;        // time between two rows up to which missing rows bridge a gap
  double jitter_fraction = 0.25;  // of sample_time_s: how far off the grid a timestamp may be
};

// `rows` as parse_csv_rows gives them (row k is spreadsheet row k + 2). Records what
// it did in the result's `repairs` and `segment_starts`. InputError naming the row
// for rows out of time order, a repeated time with different values, or a
// timestamp further off the grid than the jitter tolerance.
DataTable regularize(const DataTable& rows, const GridOptions& options, const std::string& source);

// The median time step between rows: the file's own sample time.
double median_step(const DataTable& rows);

// Averages blocks of `factor` grid rows into one sample, timed at the block's
// first row, starting afresh at each segment; a block with a missing value (or cut
// short by the end of a segment) is missing.
DataTable block_average(const DataTable& grid, int factor);

}  // namespace mpmpp
