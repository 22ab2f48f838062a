#include "mfpc/core/detail/text_format.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace mfpc::detail {

std::string group_digits(std::size_t value)
{
    std::string digits = std::to_string(value);
    for (int i = int(digits.size()) - 3; i > 0; i -= 3) digits.insert(std::size_t(i), ",");
    return digits;
}

std::string format_fixed(double value, int decimals)
{
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
    return buffer;
}

std::string format_fixed_or_na(double value, int decimals)
{
    return std::isfinite(value) ? format_fixed(value, decimals) : "n/a";
}

std::string csv_field(const std::string& text)
{
    if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
    std::string out = "\"";
    for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
}

std::string csv_row(const std::vector<std::string>& fields)
{
    std::string row;
    for (std::size_t i = 0; i < fields.size(); ++i) {
        if (i) row += ',';
        row += csv_field(fields[i]);
    }
    return row + '\n';
}

std::string key_value_rows(const std::vector<std::pair<std::string, std::string>>& rows)
{
    std::size_t width = 0;
    for (const auto& row : rows) width = std::max(width, row.first.size());
    std::string out;
    for (const auto& [key, value] : rows) out += key + std::string(width - key.size() + 2, ' ') + value + '\n';
    return out;
}

}  // namespace mfpc::detail
