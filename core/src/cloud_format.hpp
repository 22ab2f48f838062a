#pragma once

// What the PCD and PLY readers and writers share: scalar types, loading unaligned values, parsing
// numbers from text, the builder that keeps finite points with their source positions, and the
// entry points cloud_io.cpp dispatches to. Private to the core module.

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
#include "mfpc/core/point_cloud.hpp"

namespace mfpc::detail {

enum class ScalarType : std::uint8_t { int8, uint8, int16, uint16, int32, uint32, int64, uint64, float32, float64 };

std::size_t size_of(ScalarType type);
bool is_integer(ScalarType type);

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

// a * b, or nothing when it does not fit: sizes computed from header numbers must not wrap around.
inline std::optional<std::size_t> checked_product(std::size_t a, std::size_t b)
{
    if (a != 0 && b > std::numeric_limits<std::size_t>::max() / a) return std::nullopt;
    return a * b;
}

// Loads an integer scalar (a PLY list length); false when it is negative.
bool load_as_count(const std::uint8_t* bytes, ScalarType type, bool swap_bytes, std::uint64_t& count);

// Loads 4 bytes as they are (a packed rgb/rgba field).
std::uint32_t load_bits32(const std::uint8_t* bytes);

// `value` rounded to the nearest float, ±infinity beyond float's range (a plain cast would be
// undefined behaviour there). The PCD, PLY and foveation config readers send every double that
// becomes a float through here.
float narrow_to_float(double value);

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

// Rows of text data need at least two bytes a value (the value and a separator), so no more than
// this many rows can fit in `bytes`; used to cap reservations for text data, which a header can
// overstate.
std::size_t max_text_rows(std::size_t bytes, std::size_t values_per_row);

// Collects the finite points of a file in file order. A point is kept when x, y and z are all
// finite; its normal and colour are kept as read (a non-finite normal stays non-finite, so
// callers see exactly what the file said). The source index records the file position of each
// kept point and is left empty when every point was kept (the identity, see PointCloud).
class FiniteCloudBuilder {
public:
    FiniteCloudBuilder(bool with_normals, bool with_colors, std::size_t expected_points);

    void add(std::uint32_t source_position, const Point& point, const Point& normal, Rgb color)
    {
        if (!point.allFinite()) return;
        cloud_.points.push_back(point);
        if (with_normals_) cloud_.normals.push_back(normal);
        if (with_colors_) cloud_.colors.push_back(color);
        cloud_.source_index.push_back(source_position);
    }

    // Throws "no finite points" when nothing was kept.
    PointCloud finish(std::uint32_t width, std::uint32_t height, std::size_t points_in, const std::string& where);

private:
    PointCloud cloud_;
    bool with_normals_;
    bool with_colors_;
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
