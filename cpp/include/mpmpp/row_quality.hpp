#pragma once
// A historian's quality (status) column: rows it marks as not good become missing.
//
// Text codes ("Good", "Bad", "Suspect", "Uncertain", ...): good are the codes in
// `good` (compared without regard to case) or, when `good` is empty, every code
// starting with "good" ("Good", "GOOD", "Good_LocalOverride"). Numeric codes mean
// different things per historian (OPC DA 192 and OPC UA 0 are good, a PHD
// confidence of 100 is), so for them `good` must be given. An empty cell is not good.
#include <string>
#include <vector>

#include "mpmpp/data_io.hpp"

namespace mpmpp {

// Sets every value of a row that is not good to NaN, removes the quality column
// from the table, and counts the rows in repairs.bad_quality_rows.
void mask_bad_quality(DataTable& rows, const std::string& column,
                      const std::vector<std::string>& good, const std::string& source);

}  // namespace mpmpp
