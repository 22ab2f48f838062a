#pragma once

/// @file
/// @brief mfpc::PointCloud, the cloud every stage takes: finite float xyz points with optional
/// normals, colours and the source position of each point.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

/// @brief Multifoveated point clouds and 3D object recognition: every type and function of the
/// library.
namespace mfpc {

/// @brief A point (or a normal): float x, y, z, 12 bytes with no padding.
using Point = Eigen::Vector3f;

/// @brief An 8-bit colour.
struct Rgb {
    std::uint8_t r = 0;  ///< Red.
    std::uint8_t g = 0;  ///< Green.
    std::uint8_t b = 0;  ///< Blue.
    /// @brief Whether the three channels are equal.
    /// @return True when r, g and b all match.
    friend bool operator==(const Rgb&, const Rgb&) = default;
};

/// @brief The largest coordinate magnitude a cloud may hold, in its units (metres for a sensor):
/// 1e9. Float spacing at 1e9 is 64, so no surface beyond it can be described, and below it the
/// squared distances and covariance sums of any kernel stay far inside float's range; beyond it
/// FLANN's and Embree's arithmetic overflows. Readers and check_cloud refuse a point beyond it.
inline constexpr float max_coordinate = 1e9f;
/// @brief max_coordinate as errors write it.
inline constexpr const char* max_coordinate_text = "1e9";

/// @brief Whether |x|, |y| and |z| are all at most max_coordinate (false for NaN).
/// @param point The point.
/// @return True when the point lies in the supported range.
inline bool within_coordinate_range(const Point& point) noexcept
{
    return std::abs(point.x()) <= max_coordinate && std::abs(point.y()) <= max_coordinate &&
           std::abs(point.z()) <= max_coordinate;
}

/// @brief A cloud of finite points, stored as contiguous float xyz (12 bytes a point, no padding)
/// so that kernels take it as std::span<const Point>. Normals and colours are optional: each is
/// either empty or has one entry per point.
///
/// Clouds read from organized sensors keep where each point came from: source_index[i] is the
/// row-major position (row * width + column) of point i in the width x height input. An empty
/// source_index means the identity (point i was input point i).
struct PointCloud {
    std::vector<Point> points;                ///< The points, all finite.
    std::vector<Point> normals;               ///< Empty, or one normal per point.
    std::vector<Rgb> colors;                  ///< Empty, or one colour per point.
    std::vector<std::uint32_t> source_index;  ///< Empty (the identity), or each point's source position.
    std::uint32_t width = 0;   ///< Of the source grid; the point count for an unorganized cloud.
    std::uint32_t height = 1;  ///< > 1 for an organized source.

    /// @brief The number of points.
    /// @return points.size().
    std::size_t size() const noexcept { return points.size(); }
    /// @brief Whether the cloud has no points.
    /// @return points.empty().
    bool empty() const noexcept { return points.empty(); }
    /// @brief Whether the cloud carries normals.
    /// @return True when normals is not empty.
    bool has_normals() const noexcept { return !normals.empty(); }
    /// @brief Whether the cloud carries colours.
    /// @return True when colors is not empty.
    bool has_colors() const noexcept { return !colors.empty(); }
    /// @brief Whether the source was organized (a depth image).
    /// @return height > 1.
    bool organized() const noexcept { return height > 1; }
    /// @brief The number of positions in the source grid.
    /// @return width * height.
    std::size_t source_size() const noexcept { return std::size_t(width) * height; }

    /// @brief The position of point i in the source (identity when no index map is kept).
    /// @param i A point index, below size().
    /// @return source_index[i], or i when source_index is empty.
    std::uint32_t source_position(std::size_t i) const noexcept
    {
        return source_index.empty() ? static_cast<std::uint32_t>(i) : source_index[i];
    }
};

/// @brief Checks the invariants of PointCloud (attribute sizes, index map size and range, finite
/// coordinates within ±max_coordinate).
/// @param cloud The cloud to check.
/// @param what The name of the cloud, for the error.
/// @throws mfpc::Error naming `what` on the first violation.
void check_cloud(const PointCloud& cloud, const char* what = "cloud");

/// @brief A new cloud holding the points at `indices` (in that order) with their attributes and
/// source positions; the source grid size is kept.
/// @param cloud The cloud to select from.
/// @param indices Indices into `cloud` (each below cloud.size(); not checked).
/// @return The selected points, their normals and colours when `cloud` has them, and their source
/// positions as the index map.
PointCloud select(const PointCloud& cloud, std::span<const std::uint32_t> indices);

}  // namespace mfpc
