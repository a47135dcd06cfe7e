#pragma once
// The data file (FORMATS.md "Data file"): routine operating data as CSV.
//
// A header row with a `time` column and one column per variable, then one row
// per sample. Time is seconds (a number) or ISO-8601 timestamps
// ("2026-03-01T08:00:05", optional fraction, "Z" or "+01:00"; a space may replace
// the "T"). Cells that are empty or NaN are missing values: kept as NaN and
// counted, never interpolated. Every problem is an InputError with one line
// naming the file and the row and/or column, e.g.
//   data.csv: row 7, column dry_weight: "abc" is not a number
// Rows are numbered as in a spreadsheet: the header is row 1, the first sample row 2.
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "mpmpp/error.hpp"
#include "mpmpp/model.hpp"

namespace mpmpp {

struct DataTable {
  // Seconds: as written for numeric time; since the first row for timestamps
  // (a choice: results then read "alarm at 28800 s" whatever the calendar date).
  Eigen::VectorXd time_s;
  std::string time_origin;           // the first timestamp as written; empty for numeric time
  std::vector<std::string> columns;  // every column but `time`, in file order
  Eigen::MatrixXd values;            // samples x columns, NaN where missing
  std::vector<int> missing;          // number of missing values per column

  int num_samples() const { return static_cast<int>(time_s.size()); }
  int column(const std::string& name) const;  // index into columns, -1 if absent
};

// Builds a table from parts (e.g. a simulation), counting the NaNs; checks shapes,
// names (non-empty, unique, not "time"), finite strictly increasing time.
DataTable make_data_table(Eigen::VectorXd time_s, std::vector<std::string> columns, Eigen::MatrixXd values);

// `source` names the text in error messages (the file path for read_csv).
DataTable parse_csv(const std::string& text, const std::string& source);
DataTable read_csv(const std::string& path);

// The model's inputs and outputs are columns, and the time step equals
// sample_time_s to a relative tolerance of 1e-6.
void validate_data(const DataTable& data, const Model& model, const std::string& source);
DataTable load_data(const std::string& path, const Model& model);  // read_csv + validate_data

// Time in seconds, numbers in their shortest exact form, missing as empty cells.
std::string data_to_csv(const DataTable& data);
// Atomic: written to a temporary file in the same directory, then renamed over `path`.
void write_csv(const DataTable& data, const std::string& path);

}  // namespace mpmpp
