#pragma once
// Whole-file text IO for the user's files (internal to the library).
#include <string>
#include <vector>

namespace mpmpp::detail {

// The file's bytes; InputError "<path>: cannot read: <reason>" when it cannot be opened.
std::string read_text_file(const std::string& path);

// Writes `content` to a temporary file in the directory of `path`, flushes it to
// disk and renames it over `path`, so a reader never sees a half-written file and
// a failed write leaves the old file intact. InputError "<path>: cannot write: <reason>".
void write_file_atomic(const std::string& path, const std::string& content);

// Replaces bytes that are not printable ASCII so an error message quoting the
// user's (possibly binary) file stays one readable line.
std::string printable(const std::string& text, std::size_t max_length = 40);

// The shortest decimal that reads back as the same double ("0.1", "2.5e-300").
std::string format_number(double x);

// "a, b, c"
std::string comma_list(const std::vector<std::string>& names);

// The message with control characters (line breaks, tabs, ...) replaced by '?':
// every error reaches the user as exactly one line, whatever names a file holds.
std::string one_line(const std::string& message);

}  // namespace mpmpp::detail
