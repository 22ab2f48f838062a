#pragma once

// Internal to MFPC (shared by its modules, not installed): the voxel lattice of a PointIndex and
// the order of its points, for a caller that needs that order without building the index (the
// one-shot foveate, kernels/src/foveate.cpp).

#include <cstdint>
#include <limits>
#include <optional>

#include <Eigen/Core>

#include "mfpc/core/detail/floor.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc::detail {

inline constexpr std::uint64_t index_leaf_voxels = 512;  // 8 x 8 x 8, OpenVDB's PointIndexGrid leaf

// The voxel a PointIndex of this voxel size buckets a point into: OpenVDB's cell-centred
// conversion (Coord::round of the world-to-index map, in double), so that voxel (i, j, k) covers
// [i, i + 1) * voxel_size.
struct IndexLattice {
    double translation;
    double inverse;

    explicit IndexLattice(float voxel_size)
        : translation(0.5 * double(voxel_size)), inverse(1.0 / double(voxel_size))
    {
    }
    // Before the floor: Coord::round is floor(x + 0.5).
    Eigen::Array3d unfloored(const Point& p) const
    {
        return ((p.cast<double>().array() - translation) * inverse + 0.5).eval();
    }
    // Whether p is finite and lies within 2^30 voxels of the origin: far inside OpenVDB's 32-bit
    // coordinates, so that leaf origins and query boxes widened by a voxel cannot overflow.
    bool reaches(const Point& p) const { return unfloored(p).abs().maxCoeff() <= double(1 << 30); }
    // Exact while |unfloored(p)| stays below 2^31 (reaches(p) keeps it within 2^30).
    Eigen::Vector3i voxel(const Point& p) const
    {
        const Eigen::Array3d u = unfloored(p);
        return Eigen::Vector3i(floor_to<int>(u.x()), floor_to<int>(u.y()), floor_to<int>(u.z()));
    }
    // The leaf (8x8x8 voxels) holding p's voxel.
    Eigen::Vector3i leaf(const Point& p) const
    {
        return voxel(p).unaryExpr([](int c) { return c >> 3; });
    }
};

// Keys that rank voxels as PointIndex::point_order() lists their points: leaves numbered row-major
// over the leaves lo..hi, x slowest (ascending numbers are ascending origins, OpenVDB's Coord
// order), then the voxel's offset in its leaf (OpenVDB's voxel order). Within a voxel the index
// lists points by ascending number.
struct LeafNumbering {
    Eigen::Vector3i lo;
    std::uint64_t span_y = 0;
    std::uint64_t span_z = 0;
    std::uint64_t key_count = 0;  // every key is below this

    // None when the leaves lo..hi are too many to number with 64-bit keys (each span below 2^28).
    static std::optional<LeafNumbering> over(const Eigen::Vector3i& lo_leaf, const Eigen::Vector3i& hi_leaf)
    {
        const Eigen::Vector3i span = hi_leaf - lo_leaf;
        LeafNumbering n;
        n.lo = lo_leaf;
        n.span_y = std::uint64_t(span.y()) + 1;
        n.span_z = std::uint64_t(span.z()) + 1;
        const std::uint64_t span_xy = (std::uint64_t(span.x()) + 1) * n.span_y;  // below 2^56
        if (span_xy > std::numeric_limits<std::uint64_t>::max() / (n.span_z * index_leaf_voxels)) return std::nullopt;
        n.key_count = span_xy * n.span_z * index_leaf_voxels;
        return n;
    }
    static std::uint64_t offset_in_leaf(const Eigen::Vector3i& v)
    {
        return std::uint64_t(((v.x() & 7) << 6) | ((v.y() & 7) << 3) | (v.z() & 7));
    }
    // The key of voxel v, whose leaf must lie within lo..hi.
    std::uint64_t key(const Eigen::Vector3i& v) const
    {
        const Eigen::Vector3i leaf = v.unaryExpr([](int c) { return c >> 3; }) - lo;
        return ((std::uint64_t(leaf.x()) * span_y + std::uint64_t(leaf.y())) * span_z + std::uint64_t(leaf.z())) *
                   index_leaf_voxels +
               offset_in_leaf(v);
    }
};

}  // namespace mfpc::detail
