#pragma once

// Internal (not installed): reading words and numbers from text headers and data (PCD, PLY, OBJ,
// the foveation config), and quoting what was read in a one-line error message.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace mfpc::detail {

// Whole-token parsers for text data: false when the token is not entirely a number of that kind
// or is out of range. A leading '+' is accepted; "nan" and "inf" are accepted by the float ones.
bool parse_float(std::string_view token, float& value);
bool parse_double(std::string_view token, double& value);
bool parse_unsigned(std::string_view token, std::uint64_t& value);
bool parse_signed(std::string_view token, std::int64_t& value);

// Splits a line at spaces, tabs and carriage returns into `tokens` (cleared first).
void split_words(std::string_view line, std::vector<std::string_view>& tokens);

// `text` quoted for a one-line error message: at most 60 characters, control bytes shown as '?'.
// Also used by the foveation config reader for every piece of user text it reports.
std::string quoted(std::string_view text);

}  // namespace mfpc::detail
