#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "mfpc/core/box.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

struct PointIndexParams {
    // Edge of one index voxel (metres). Points are bucketed into voxels, voxels into leaves of
    // 8x8x8 voxels (OpenVDB's PointIndexGrid). Labelling cost grows with the leaves that straddle a
    // box face, so smaller voxels mean fewer points tested per straddling leaf but more leaves.
    float voxel_size = 0.01f;
};

// One leaf of the index: the points it holds (a range of point_order()) and their tight bounds.
// The bounds are the min/max of the float coordinates themselves, not the nominal voxel extent,
// so "every point of this leaf is inside box B" is exactly bounds ⊆ B.
struct PointIndexLeaf {
    Box bounds;
    std::uint32_t begin = 0;
    std::uint32_t end = 0;
    std::uint32_t size() const { return end - begin; }
};

// A cloud bucketed once into an OpenVDB sparse grid (tools::PointIndexGrid), reusable for any
// number of box, radius and foveation queries while the cloud does not change. The index refers to
// the caller's points (it keeps a view, not a copy): they must outlive it and stay unchanged.
class PointIndex {
public:
    explicit PointIndex(std::span<const Point> points, const PointIndexParams& params = {});
    ~PointIndex();
    PointIndex(PointIndex&&) noexcept;
    PointIndex& operator=(PointIndex&&) noexcept;
    PointIndex(const PointIndex&) = delete;
    PointIndex& operator=(const PointIndex&) = delete;

    std::span<const Point> points() const { return points_; }
    const PointIndexParams& params() const { return params_; }

    // Leaves in a fixed order (by leaf origin), each with its points' index range in point_order().
    std::span<const PointIndexLeaf> leaves() const { return leaves_; }
    // Every point index exactly once, grouped by leaf; ascending within a leaf.
    std::span<const std::uint32_t> point_order() const { return point_order_; }

    // Indices of the points inside `box` (closed), ascending, appended to `out` after clearing it.
    void points_in_box(const Box& box, std::vector<std::uint32_t>& out) const;
    // Indices of the points within `radius` of `center` (distance <= radius), ascending.
    void points_in_radius(const Point& center, float radius, std::vector<std::uint32_t>& out) const;

    // Bytes held by the grid and the leaf table.
    std::size_t memory_bytes() const;

private:
    struct Grid;
    std::span<const Point> points_;
    PointIndexParams params_;
    std::unique_ptr<Grid> grid_;
    std::vector<PointIndexLeaf> leaves_;
    std::vector<std::uint32_t> point_order_;
};

}  // namespace mfpc
