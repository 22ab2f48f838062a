#pragma once

// Internal (not installed): the number and field formats every report of the library and the
// command line share, so that a table, a CSV row and a progress line print a value the same way.

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace mfpc::detail {

// "307,200"
std::string group_digits(std::size_t value);

// printf's "%.*f": "0.125" for (0.125, 3).
std::string format_fixed(double value, int decimals);

// format_fixed for finite values, "n/a" for NaN and infinities (a summary of one run has no interval).
std::string format_fixed_or_na(double value, int decimals);

// A CSV field, quoted when it holds a separator, a quote or a line break (an error message may).
std::string csv_field(const std::string& text);

// The fields as one CSV line with its line break.
std::string csv_row(const std::vector<std::string>& fields);

// A two-column table with the keys aligned, one "key  value" line per row.
std::string key_value_rows(const std::vector<std::pair<std::string, std::string>>& rows);

}  // namespace mfpc::detail
