#pragma once

// What the PCD and PLY readers and writers share: loading unaligned values of a ScalarType, the
// builder that keeps finite points with their source positions, and the entry points cloud_io.cpp
// dispatches to. Private to the core module; the scalar types and the text parsers are in detail/,
// where the mesh reader in tools/ finds them too.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/detail/scalar_type.hpp"
#include "mfpc/core/detail/text_parse.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc::detail {

// Loads the scalar stored at `bytes` (any alignment; `swap_bytes` for the opposite byte order) and
// converts it to float; a double beyond float's range becomes ±infinity.
float load_any_as_float(const std::uint8_t* bytes, ScalarType type, bool swap_bytes);

// The same, with the common case (a float in host order) inline: it is most of every read.
inline float load_as_float(const std::uint8_t* bytes, ScalarType type, bool swap_bytes)
{
    if (type == ScalarType::float32 && !swap_bytes) {
        float value;
        std::memcpy(&value, bytes, sizeof(value));
        return value;
    }
    return load_any_as_float(bytes, type, swap_bytes);
}

// The same as a double, exactly for every type but a 64-bit integer beyond 2^53.
double load_as_double(const std::uint8_t* bytes, ScalarType type, bool swap_bytes);

// a * b, or nothing when it does not fit: sizes computed from header numbers must not wrap around.
inline std::optional<std::size_t> checked_product(std::size_t a, std::size_t b)
{
    if (a != 0 && b > std::numeric_limits<std::size_t>::max() / a) return std::nullopt;
    return a * b;
}

// Loads an integer scalar (a PLY list length); false when it is negative.
bool load_as_count(const std::uint8_t* bytes, ScalarType type, bool swap_bytes, std::uint64_t& count);

// Loads 4 bytes as they are (a packed rgb/rgba field).
inline std::uint32_t load_bits32(const std::uint8_t* bytes)
{
    std::uint32_t value;
    std::memcpy(&value, bytes, sizeof(value));
    return value;
}

// `value` rounded to the nearest float, ±infinity beyond float's range (a plain cast would be
// undefined behaviour there). The PCD, PLY and foveation config readers send every double that
// becomes a float through here; inline, because the PLY reader does so for every value.
inline float narrow_to_float(double value)
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

// Rows of text data need at least two bytes a value (the value and a separator), so no more than
// this many rows can fit in `bytes`; used to cap reservations for text data, which a header can
// overstate.
std::size_t max_text_rows(std::size_t bytes, std::size_t values_per_row);

// Collects the finite points of a file in file order. A point is kept when x, y and z are all
// finite; its normal and colour are kept as read (a non-finite normal stays non-finite, so
// callers see exactly what the file said). The source index records the file position of each
// kept point and is left empty when every point was kept (the identity, see PointCloud).
//
// Given `zero_points` (an organized file), a pixel at exactly (0, 0, 0) is an invalid pixel, as
// NaN is: a depth sensor cannot measure its own centre, and drivers that write zeros for missing
// depth would otherwise pile thousands of points onto one spot. They are counted there.
// A finite point beyond ±max_coordinate is an error, raised by finish().
class FiniteCloudBuilder {
public:
    FiniteCloudBuilder(bool with_normals, bool with_colors, std::size_t expected_points,
                       std::size_t* zero_points = nullptr);

    // Inlined into each reader loop (a call per point was a tenth of reading a binary scene).
    [[gnu::always_inline]] void add(std::uint32_t source_position, const Point& point, const Point& normal, Rgb color)
    {
        if (!point.allFinite()) return;
        if (zero_points_ && point.x() == 0.0f && point.y() == 0.0f && point.z() == 0.0f) {
            ++*zero_points_;
            return;
        }
        if (!within_coordinate_range(point) && !beyond_range_) beyond_range_ = source_position;
        cloud_.points.push_back(point);
        if (with_normals_) cloud_.normals.push_back(normal);
        if (with_colors_) cloud_.colors.push_back(color);
        cloud_.source_index.push_back(source_position);
    }

    // Throws "no finite points" when nothing was kept, and for a point beyond the range.
    PointCloud finish(std::uint32_t width, std::uint32_t height, std::size_t points_in, const std::string& where);

private:
    PointCloud cloud_;
    bool with_normals_;
    bool with_colors_;
    std::size_t* zero_points_;
    std::optional<std::uint32_t> beyond_range_;  // file position of the first point beyond it
};

// `file` is the whole file; `where` names it in errors.
PointCloud read_pcd(std::span<const std::uint8_t> file, const std::string& where, CloudReadReport& report);
PointCloud read_ply(std::span<const std::uint8_t> file, const std::string& where, CloudReadReport& report);

// The complete bytes of a file holding `cloud` (already checked with check_cloud and not empty).
std::string pcd_file_bytes(const PointCloud& cloud, const CloudWriteOptions& options, const std::string& where);
std::string ply_file_bytes(const PointCloud& cloud, const CloudWriteOptions& options, const std::string& where);

// Appends the shortest text that reads back as exactly `value` ("nan", "inf" for those).
void append_float(std::string& out, float value);

}  // namespace mfpc::detail
