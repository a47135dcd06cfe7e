#pragma once
// The data file (docs/formats.md "Data file"): routine operating data as CSV.
//
// A header row with a `time` column and one column per variable, then one row
// per sample. Time is seconds (a number), Unix epoch seconds (a number of at
// least kEpochThresholdS) or ISO-8601 timestamps ("2026-03-01T08:00:05",
// optional fraction, "Z" or "+01:00"; a space may replace the "T"). Cells that
// are empty or NaN are missing values: kept as NaN and counted, never
// interpolated; so are a historian's status words in a numeric column ("Bad
// Input"; counted in repairs.status_words). A column with no number at all (a
// historian status or tag-name column) is kept apart as text. Every problem is an InputError with
// one line naming the file and the row and/or column, e.g.
//   data.csv: row 7, column dry_weight: "abc" is not a number
// Rows are numbered as in a spreadsheet: the header is row 1, the first sample row 2.
#include <Eigen/Dense>
#include <string>
#include <utility>
#include <vector>

#include "mpmpp/error.hpp"
#include "mpmpp/limits.hpp"
#include "mpmpp/model.hpp"

namespace mpmpp {

// A numeric time column starting at or after 2001-09-09T01:46:40Z (1e9 s) holds
// Unix epoch seconds: no plant record is 31 years long in seconds from its start.
constexpr double kEpochThresholdS = 1e9;

// How the file wrote its time; timestamps and epoch seconds are calendar time.
enum class TimeKind { Seconds, EpochSeconds, Timestamp, LocalTimestamp };

// What was repaired on the way from the file to the regular sample grid
// (time_grid.hpp, row_quality.hpp); all zero for a file already on the grid.
struct DataRepairs {
  struct Gap {
    double start_s = 0, end_s = 0;  // the last sample before and the first after
    int missing_rows = 0;           // rows added as missing (0 for a split)
    bool split = false;             // longer than the largest gap bridged: a new segment
  };
  // A historian's status words in a numeric column ("Bad Input", "I/O Timeout"), read as
  // missing values.
  struct StatusWords {
    std::string column;
    int cells = 0;      // how many
    std::string first;  // the first one, as written
  };
  int jitter_snapped = 0;      // rows moved onto the grid
  double max_jitter_s = 0;     // the largest such move
  int duplicates_dropped = 0;  // repeated rows (same time, same values)
  std::vector<Gap> gaps;
  int bad_quality_rows = 0;               // rows masked by the quality column
  std::vector<std::string> text_columns;  // columns without numbers, not used as data
  std::vector<StatusWords> status_words;  // per numeric column that has them, in file order
  int resample_factor = 1;                // raw samples averaged per sample (1: none)
  double raw_sample_time_s = 0;           // the file's own sample time when resampled
};

struct DataTable {
  // Seconds: as written for plain numeric time; since the first row for calendar
  // time (timestamps, epoch seconds), whose start is origin_epoch_s.
  Eigen::VectorXd time_s;
  std::string time_origin;  // the first timestamp as written (ISO-8601 for epoch seconds); empty
                            // for plain seconds
  TimeKind time_kind = TimeKind::Seconds;
  double origin_epoch_s = 0;  // Unix time of time_s = 0 (local timestamps: as if UTC)
  // The UTC offsets the timestamps carry: (time_s, offset_s) from that time on, the first
  // at the first row; more than one when daylight saving time starts or ends in the file.
  std::vector<std::pair<double, int>> utc_offsets;
  std::vector<std::string> columns;       // every numeric column but `time`, in file order
  Eigen::MatrixXd values;                 // samples x columns, NaN where missing
  std::vector<int> missing;               // number of missing values per column
  std::vector<std::string> text_columns;  // columns with no number at all
  std::vector<std::vector<std::string>> text_values;  // their cells, per column
  std::vector<int> segment_starts;  // rows after a split gap (a missing row marks each break)
  DataRepairs repairs;

  int num_samples() const { return static_cast<int>(time_s.size()); }
  int column(const std::string& name) const;  // index into columns, -1 if absent
};

// A time of the table as the file writes it: "3605 s" for plain seconds, else an
// ISO-8601 timestamp in the UTC offset the file uses at that time
// ("2026-03-01T09:00:05+01:00"; no offset for local timestamps, "Z" for epoch seconds).
std::string format_time(const DataTable& data, double time_s);
// The UTC offset in seconds the file's timestamps carry at `time_s` (0 without one).
int utc_offset_at(const DataTable& data, double time_s);

// Builds a table from parts (e.g. a simulation), counting the NaNs; checks shapes,
// names (non-empty, unique, not "time"), finite strictly increasing time.
DataTable make_data_table(Eigen::VectorXd time_s, std::vector<std::string> columns,
                          Eigen::MatrixXd values);

// `source` names the text in error messages (the file path for read_csv).
// Time must be strictly increasing.
DataTable parse_csv(const std::string& text, const std::string& source);
DataTable read_csv(const std::string& path);
// The rows as written (time in file order, not yet checked), for the repairs of load_data.
DataTable parse_csv_rows(const std::string& text, const std::string& source);
DataTable read_csv_rows(const std::string& path);

// The model's inputs and outputs are numeric columns, and within each segment the
// time step equals sample_time_s to a relative tolerance of 1e-6.
void validate_data(const DataTable& data, const Model& model, const std::string& source);

// How load_data turns a historian export into the model's sample grid.
struct LoadOptions {
  double max_gap_s =
      -1;  // gaps up to this become missing rows, longer ones split; < 0: 10 sample times
  double jitter_fraction =
      0.25;  // timestamps this fraction of a sample time off the grid are snapped
  double resample_s =
      0;  // > 0: block-average faster data to this sample time (must be the model's)
  std::string quality_column;             // rows whose quality is not good become missing
  std::vector<std::string> good_quality;  // good codes; empty: text starting with "good"
};

// parse_csv_rows, quality mask, grid repairs (time_grid.hpp), validate_data.
DataTable load_data(const std::string& path, const Model& model, const LoadOptions& options = {});
DataTable load_data_text(const std::string& text, const std::string& source, const Model& model,
                         const LoadOptions& options = {});

// Time in seconds, numbers in their shortest exact form, missing as empty cells.
std::string data_to_csv(const DataTable& data);
// Atomic: written to a temporary file in the same directory, then renamed over `path`.
void write_csv(const DataTable& data, const std::string& path);

}  // namespace mpmpp
