#pragma once

/// @file
/// @brief PointIndex, a cloud bucketed once into an OpenVDB sparse grid for box, radius and
/// foveation queries.

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "mfpc/core/box.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

/// The smallest index voxel (metres): 0.1 mm, ten times OpenVDB's own limit.
inline constexpr float min_index_voxel_size = 1e-4f;

/// @brief How a PointIndex buckets its cloud.
struct PointIndexParams {
    /// @brief Edge of one index voxel (metres).
    ///
    /// Points are bucketed into voxels, voxels into leaves of 8x8x8 voxels (OpenVDB's
    /// PointIndexGrid). Labelling decides whole leaves, then whole voxels, and tests single points
    /// only in voxels that straddle a box face; smaller voxels mean fewer such points but more
    /// voxels to decide and a slower build. Voxels are aligned with the world origin; downsampling
    /// is fastest when the densities d_k are multiples of this size. At least
    /// min_index_voxel_size.
    float voxel_size = 0.005f;
};

/// @brief One occupied voxel of the index: the points it holds (a range of point_order()), their
/// tight bounds and their sum (so a downsampling voxel can take a whole index voxel without its
/// points).
///
/// Tight bounds are the min/max of the float coordinates themselves, not the voxel's nominal
/// extent, so "every point of this voxel is inside box B" is exactly bounds ⊆ B.
struct PointIndexVoxel {
    Box bounds;  ///< The tight bounds of its points.
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();  ///< Of its points, in double, in point_order().
    std::uint32_t begin = 0;  ///< First position of its points in point_order().
    std::uint32_t end = 0;    ///< One past the last.
    /// @brief The number of points.
    /// @return end - begin.
    std::uint32_t size() const { return end - begin; }
};

/// @brief One leaf (8x8x8 voxels): its occupied voxels (a range of voxels()), their points (a
/// range of point_order()) and the tight bounds of those points.
struct PointIndexLeaf {
    Box bounds;                     ///< The tight bounds of its points.
    std::uint32_t begin = 0;        ///< First position of its points in point_order().
    std::uint32_t end = 0;          ///< One past the last.
    std::uint32_t voxel_begin = 0;  ///< Its first voxel in voxels().
    std::uint32_t voxel_end = 0;    ///< One past its last.
    /// @brief The number of points.
    /// @return end - begin.
    std::uint32_t size() const { return end - begin; }
};

/// @brief A cloud bucketed once into an OpenVDB sparse grid (tools::PointIndexGrid), reusable for
/// any number of box, radius and foveation queries while the cloud does not change.
///
/// The index refers to the caller's points (points() is a view of them): they must outlive it and
/// stay unchanged.
class PointIndex {
public:
    /// @brief Indexes `points`.
    /// @param points The cloud; it must outlive the index and stay unchanged.
    /// @param params The index voxel size.
    /// @throws mfpc::Error for a voxel size that is not positive and finite or below
    /// min_index_voxel_size, 2^32 points or more, or a point that is not finite or lies more than
    /// 2^30 voxels from the origin.
    explicit PointIndex(std::span<const Point> points, const PointIndexParams& params = {});
    /// @brief Indexes the cloud's points and, when it has colours, also keeps each voxel's colour
    /// sums, so voxel downsampling of a coloured cloud takes whole voxels without reading their
    /// colours.
    ///
    /// As for the points, the cloud's colours must outlive the index and stay unchanged: the sums
    /// are not recomputed, and a temporary cloud would leave the index dangling, hence the deleted
    /// overload.
    /// @param cloud The cloud.
    /// @param params The index voxel size.
    /// @throws mfpc::Error as the constructor from points, and for a cloud whose colour count is not
    /// its point count.
    explicit PointIndex(const PointCloud& cloud, const PointIndexParams& params = {});
    /// @brief Deleted: a temporary cloud would leave the index dangling.
    PointIndex(PointCloud&&, const PointIndexParams& = {}) = delete;
    /// @brief Frees the grid and the tables.
    ~PointIndex();
    /// @brief Moves the index; the points it refers to stay where they are.
    PointIndex(PointIndex&&) noexcept;
    /// @brief Move-assigns the index; the points it refers to stay where they are.
    /// @return This index.
    PointIndex& operator=(PointIndex&&) noexcept;
    /// @brief Not copyable.
    PointIndex(const PointIndex&) = delete;
    /// @brief Not copyable.
    PointIndex& operator=(const PointIndex&) = delete;

    /// @brief The indexed points.
    /// @return A view of the caller's points.
    std::span<const Point> points() const { return points_; }
    /// @brief The parameters the index was built with.
    /// @return The parameters.
    const PointIndexParams& params() const { return params_; }

    /// @brief The occupied leaves, in a fixed order (by leaf origin).
    /// @return The leaves.
    std::span<const PointIndexLeaf> leaves() const { return leaves_; }
    /// @brief The occupied voxels, grouped by leaf, in OpenVDB's voxel order within a leaf.
    /// @return The voxels.
    std::span<const PointIndexVoxel> voxels() const { return voxels_; }
    /// @brief Every point index exactly once, grouped by voxel (so by leaf); ascending within a
    /// voxel.
    /// @return The point order.
    std::span<const std::uint32_t> point_order() const { return point_order_; }
    /// @brief The points themselves in point_order(): ordered_points()[k] ==
    /// points()[point_order()[k]].
    ///
    /// A copy (12 bytes a point) that lets kernels read a voxel's points from contiguous memory
    /// instead of gathering them across the cloud.
    /// @return The ordered copy.
    std::span<const Point> ordered_points() const { return ordered_points_; }
    /// @brief Per voxel (as voxels()), the sums of its points' r, g and b, when built from a
    /// coloured cloud; empty otherwise.
    /// @return The colour sums.
    std::span<const std::array<std::uint64_t, 3>> voxel_color_sums() const { return voxel_color_sums_; }
    /// @brief Whether those sums are of `cloud`'s colours: the same storage and size (an index
    /// built from another or since-resized colour array must not be trusted).
    /// @param cloud The cloud whose colours are to be downsampled.
    /// @return True when the index holds colour sums of exactly that colour array.
    bool sums_colors_of(const PointCloud& cloud) const
    {
        return !voxel_color_sums_.empty() && colors_.data() == cloud.colors.data() &&
               colors_.size() == cloud.colors.size();
    }

    /// @brief Indices of the points inside `box` (closed), ascending, appended to `out` after
    /// clearing it. None for an invalid box.
    /// @param box The box.
    /// @param out Receives the indices.
    void points_in_box(const Box& box, std::vector<std::uint32_t>& out) const;
    /// @brief Indices of the points within `radius` of `center` (distance <= radius), ascending,
    /// appended to `out` after clearing it. None for a negative radius.
    /// @param center The centre.
    /// @param radius The radius.
    /// @param out Receives the indices.
    void points_in_radius(const Point& center, float radius, std::vector<std::uint32_t>& out) const;

    /// @brief Bytes held by the grid and the leaf table.
    /// @return The bytes of the OpenVDB grid and of the index's tables (leaves, voxels, point
    /// order, ordered points, colour sums).
    std::size_t memory_bytes() const;

private:
    struct Grid;
    std::span<const Point> points_;
    PointIndexParams params_;
    std::unique_ptr<Grid> grid_;
    std::vector<PointIndexLeaf> leaves_;
    std::vector<PointIndexVoxel> voxels_;
    std::vector<std::uint32_t> point_order_;
    std::vector<Point> ordered_points_;
    std::span<const Rgb> colors_;
    std::vector<std::array<std::uint64_t, 3>> voxel_color_sums_;
};

}  // namespace mfpc
