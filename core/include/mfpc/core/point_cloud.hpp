#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <Eigen/Core>

namespace mfpc {

using Point = Eigen::Vector3f;

struct Rgb {
    std::uint8_t r = 0;
    std::uint8_t g = 0;
    std::uint8_t b = 0;
    friend bool operator==(const Rgb&, const Rgb&) = default;
};

// A cloud of finite points, stored as contiguous float xyz (12 bytes a point, no padding) so that
// kernels take it as std::span<const Point>. Normals and colours are optional: each is either
// empty or has one entry per point.
//
// Clouds read from organized sensors keep where each point came from: source_index[i] is the
// row-major position (row * width + column) of point i in the width x height input. An empty
// source_index means the identity (point i was input point i).
struct PointCloud {
    std::vector<Point> points;
    std::vector<Point> normals;
    std::vector<Rgb> colors;
    std::vector<std::uint32_t> source_index;
    std::uint32_t width = 0;   // of the source grid; the point count for an unorganized cloud
    std::uint32_t height = 1;  // > 1 for an organized source

    std::size_t size() const noexcept { return points.size(); }
    bool empty() const noexcept { return points.empty(); }
    bool has_normals() const noexcept { return !normals.empty(); }
    bool has_colors() const noexcept { return !colors.empty(); }
    bool organized() const noexcept { return height > 1; }
    std::size_t source_size() const noexcept { return std::size_t(width) * height; }

    // The position of point i in the source (identity when no index map is kept).
    std::uint32_t source_position(std::size_t i) const noexcept
    {
        return source_index.empty() ? static_cast<std::uint32_t>(i) : source_index[i];
    }
};

// Checks the invariants above (attribute sizes, index map size and range, finite coordinates);
// throws mfpc::Error naming `what` on the first violation.
void check_cloud(const PointCloud& cloud, const char* what = "cloud");

// A new cloud holding the points at `indices` (in that order) with their attributes and source
// positions; the source grid size is kept.
PointCloud select(const PointCloud& cloud, std::span<const std::uint32_t> indices);

}  // namespace mfpc
