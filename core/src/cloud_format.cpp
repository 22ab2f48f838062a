#include "cloud_format.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
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

}  // namespace

double load_as_double(const std::uint8_t* bytes, ScalarType type, bool swap_bytes)
{
    switch (type) {
    case ScalarType::int8: return load<std::int8_t>(bytes, false);
    case ScalarType::uint8: return bytes[0];
    case ScalarType::int16: return load<std::int16_t>(bytes, swap_bytes);
    case ScalarType::uint16: return load<std::uint16_t>(bytes, swap_bytes);
    case ScalarType::int32: return load<std::int32_t>(bytes, swap_bytes);
    case ScalarType::uint32: return load<std::uint32_t>(bytes, swap_bytes);
    case ScalarType::int64: return static_cast<double>(load<std::int64_t>(bytes, swap_bytes));
    case ScalarType::uint64: return static_cast<double>(load<std::uint64_t>(bytes, swap_bytes));
    case ScalarType::float32: return load<float>(bytes, swap_bytes);
    case ScalarType::float64: return load<double>(bytes, swap_bytes);
    }
    return std::numeric_limits<double>::quiet_NaN();
}

float load_any_as_float(const std::uint8_t* bytes, ScalarType type, bool swap_bytes)
{
    // A 64-bit integer goes straight to float: through a double it could be rounded twice.
    if (type == ScalarType::int64) return static_cast<float>(load<std::int64_t>(bytes, swap_bytes));
    if (type == ScalarType::uint64) return static_cast<float>(load<std::uint64_t>(bytes, swap_bytes));
    return narrow_to_float(load_as_double(bytes, type, swap_bytes));
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

std::size_t max_text_rows(std::size_t bytes, std::size_t values_per_row)
{
    return bytes / (2 * std::max<std::size_t>(values_per_row, 1)) + 1;
}

FiniteCloudBuilder::FiniteCloudBuilder(bool with_normals, bool with_colors, std::size_t expected_points,
                                       std::size_t* zero_points)
    : with_normals_(with_normals), with_colors_(with_colors), zero_points_(zero_points)
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
        throw Error(where, zero_points_ && *zero_points_ > 0
                               ? "no valid points (each of the " + std::to_string(points_in) +
                                     " has a NaN or infinite x, y or z, or is an invalid pixel at (0, 0, 0))"
                               : "no finite points (all " + std::to_string(points_in) +
                                     " have a NaN or infinite x, y or z)");
    }
    if (beyond_range_) {
        throw Error(where, "point " + std::to_string(*beyond_range_) + " has a coordinate beyond ±" +
                               max_coordinate_text + ", the supported range");
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
