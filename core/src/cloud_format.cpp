#include "cloud_format.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <utility>

#include "mfpc/core/error.hpp"

namespace mfpc::detail {

static_assert(std::endian::native == std::endian::little,
              "PCD binary data is little endian as PCL writes it on x86 and ARM; a big-endian host would "
              "need byte swapping in the PCD reader and writer");

namespace {

template <typename T>
T load(const std::uint8_t* bytes, bool swap_bytes)
{
    std::uint8_t copy[sizeof(T)];
    std::memcpy(copy, bytes, sizeof(T));
    if (swap_bytes) std::reverse(copy, copy + sizeof(T));
    T value;
    std::memcpy(&value, copy, sizeof(T));
    return value;
}

std::string_view without_plus(std::string_view token)
{
    // from_chars rejects a leading '+', which other writers emit.
    if (token.size() > 1 && token.front() == '+' && token[1] != '-') token.remove_prefix(1);
    return token;
}

template <typename T>
bool parse_whole(std::string_view token, T& value)
{
    token = without_plus(token);
    if (token.empty()) return false;
    T parsed{};
    const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), parsed);
    if (error != std::errc() || end != token.data() + token.size()) return false;
    value = parsed;
    return true;
}

}  // namespace

std::size_t size_of(ScalarType type)
{
    switch (type) {
    case ScalarType::int8:
    case ScalarType::uint8: return 1;
    case ScalarType::int16:
    case ScalarType::uint16: return 2;
    case ScalarType::int32:
    case ScalarType::uint32:
    case ScalarType::float32: return 4;
    case ScalarType::int64:
    case ScalarType::uint64:
    case ScalarType::float64: return 8;
    }
    return 0;
}

bool is_integer(ScalarType type)
{
    return type != ScalarType::float32 && type != ScalarType::float64;
}

float narrow_to_float(double value)
{
    constexpr double largest = std::numeric_limits<float>::max();
    // Halfway from the largest float to 2^128: from here on, round-to-nearest gives infinity.
    // Below it a number still rounds to the largest float ("3.4028235e38", FLT_MAX's shortest
    // text, is a little above FLT_MAX), so that case is answered here rather than left to a cast.
    constexpr double overflow = 0x1.ffffffp127;
    if (value >= overflow) return std::numeric_limits<float>::infinity();
    if (value <= -overflow) return -std::numeric_limits<float>::infinity();
    if (value > largest) return std::numeric_limits<float>::max();
    if (value < -largest) return -std::numeric_limits<float>::max();
    return static_cast<float>(value);
}

float load_any_as_float(const std::uint8_t* bytes, ScalarType type, bool swap_bytes)
{
    switch (type) {
    case ScalarType::int8: return static_cast<float>(load<std::int8_t>(bytes, false));
    case ScalarType::uint8: return static_cast<float>(bytes[0]);
    case ScalarType::int16: return static_cast<float>(load<std::int16_t>(bytes, swap_bytes));
    case ScalarType::uint16: return static_cast<float>(load<std::uint16_t>(bytes, swap_bytes));
    case ScalarType::int32: return static_cast<float>(load<std::int32_t>(bytes, swap_bytes));
    case ScalarType::uint32: return static_cast<float>(load<std::uint32_t>(bytes, swap_bytes));
    case ScalarType::int64: return static_cast<float>(load<std::int64_t>(bytes, swap_bytes));
    case ScalarType::uint64: return static_cast<float>(load<std::uint64_t>(bytes, swap_bytes));
    case ScalarType::float32: return load<float>(bytes, swap_bytes);
    case ScalarType::float64: return narrow_to_float(load<double>(bytes, swap_bytes));
    }
    return std::numeric_limits<float>::quiet_NaN();
}

bool load_as_count(const std::uint8_t* bytes, ScalarType type, bool swap_bytes, std::uint64_t& count)
{
    std::int64_t signed_value = 0;
    switch (type) {
    case ScalarType::uint8: count = bytes[0]; return true;
    case ScalarType::uint16: count = load<std::uint16_t>(bytes, swap_bytes); return true;
    case ScalarType::uint32: count = load<std::uint32_t>(bytes, swap_bytes); return true;
    case ScalarType::uint64: count = load<std::uint64_t>(bytes, swap_bytes); return true;
    case ScalarType::int8: signed_value = load<std::int8_t>(bytes, false); break;
    case ScalarType::int16: signed_value = load<std::int16_t>(bytes, swap_bytes); break;
    case ScalarType::int32: signed_value = load<std::int32_t>(bytes, swap_bytes); break;
    case ScalarType::int64: signed_value = load<std::int64_t>(bytes, swap_bytes); break;
    case ScalarType::float32:
    case ScalarType::float64: return false;
    }
    if (signed_value < 0) return false;
    count = static_cast<std::uint64_t>(signed_value);
    return true;
}

std::uint32_t load_bits32(const std::uint8_t* bytes)
{
    return load<std::uint32_t>(bytes, false);
}

bool parse_float(std::string_view token, float& value)
{
    return parse_whole(token, value);
}

bool parse_double(std::string_view token, double& value)
{
    return parse_whole(token, value);
}

bool parse_unsigned(std::string_view token, std::uint64_t& value)
{
    return parse_whole(token, value);
}

bool parse_signed(std::string_view token, std::int64_t& value)
{
    return parse_whole(token, value);
}

void split_words(std::string_view line, std::vector<std::string_view>& tokens)
{
    tokens.clear();
    const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
    std::size_t pos = 0;
    while (pos < line.size()) {
        while (pos < line.size() && is_space(line[pos])) ++pos;
        const std::size_t start = pos;
        while (pos < line.size() && !is_space(line[pos])) ++pos;
        if (pos > start) tokens.push_back(line.substr(start, pos - start));
    }
}

std::string quoted(std::string_view text)
{
    constexpr std::size_t longest = 60;
    std::string out = "'";
    for (std::size_t i = 0; i < text.size() && i < longest; ++i) {
        const auto c = static_cast<unsigned char>(text[i]);
        out += (c >= 32 && c < 127) ? static_cast<char>(c) : '?';
    }
    if (text.size() > longest) out += "...";
    out += "'";
    return out;
}

std::size_t max_text_rows(std::size_t bytes, std::size_t values_per_row)
{
    return bytes / (2 * std::max<std::size_t>(values_per_row, 1)) + 1;
}

FiniteCloudBuilder::FiniteCloudBuilder(bool with_normals, bool with_colors, std::size_t expected_points)
    : with_normals_(with_normals), with_colors_(with_colors)
{
    cloud_.points.reserve(expected_points);
    cloud_.source_index.reserve(expected_points);
    if (with_normals_) cloud_.normals.reserve(expected_points);
    if (with_colors_) cloud_.colors.reserve(expected_points);
}

PointCloud FiniteCloudBuilder::finish(std::uint32_t width, std::uint32_t height, std::size_t points_in,
                                      const std::string& where)
{
    if (cloud_.points.empty()) {
        throw Error(where, "no finite points (all " + std::to_string(points_in) + " have a NaN or infinite x, y or z)");
    }
    // Positions are added in increasing order, so keeping all of them means the identity.
    if (cloud_.points.size() == points_in) {
        cloud_.source_index.clear();
        cloud_.source_index.shrink_to_fit();
    }
    cloud_.width = width;
    cloud_.height = height;
    return std::move(cloud_);
}

void append_float(std::string& out, float value)
{
    char buffer[32];
    const auto [end, error] = std::to_chars(buffer, buffer + sizeof(buffer), value);
    // 32 characters hold any float in shortest form ("-1.17549435e-38" is the longest kind).
    out.append(buffer, error == std::errc() ? end : buffer);
}

}  // namespace mfpc::detail
