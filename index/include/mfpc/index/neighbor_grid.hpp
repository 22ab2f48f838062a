#pragma once

/// @file
/// @brief NeighborGrid, the exact radius and k-nearest search of the descriptor kernels, and
/// Neighborhoods, radius neighbourhoods computed once and shared between kernels.

#include <cstdint>
#include <span>
#include <vector>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

/// @brief The radius neighbourhoods of many centres, packed one after another: centre i's
/// neighbours are entries [offsets[i], offsets[i + 1]) of indices and squared_distances, in
/// radius_search's order.
///
/// Kernels that each need a support of at most `radius` around the same centres (the LRF and SHOT
/// of the keypoints) read them here instead of each searching again. Made by
/// NeighborGrid::radius_neighborhoods.
struct Neighborhoods {
    std::span<const Point> surface;  ///< The searched grid's points, which indices number.
    std::vector<Point> centers;      ///< The centres, in the order they were given.
    float radius = 0.0f;             ///< The search radius (squared distance < radius^2).
    std::vector<std::size_t> offsets{0};  ///< size() + 1 entries into indices and squared_distances.
    std::vector<std::uint32_t> indices;   ///< The neighbours' indices into surface, centre after centre.
    std::vector<float> squared_distances;  ///< The neighbours' squared distances, as indices.

    /// @brief The number of centres.
    /// @return offsets.size() - 1.
    std::size_t size() const { return offsets.size() - 1; }
    /// @brief Whether these are neighbourhoods in `points` of exactly `at` (bit for bit): what a
    /// kernel given them in place of its own searches must check.
    /// @param points The surface the kernel searches (the same storage and size as surface).
    /// @param at The kernel's centres (compared bit for bit with centers).
    /// @return Whether both match.
    bool is_of(std::span<const Point> points, std::span<const Point> at) const;
    /// @brief The check of a kernel given these neighbourhoods, for `what` it computes.
    /// @param points The surface the kernel searches.
    /// @param at The kernel's centres.
    /// @param needed The radius the kernel needs.
    /// @param where The kernel, for the error.
    /// @param what What the kernel computes, for the error.
    /// @throws mfpc::Error (naming `where`) unless these are neighbourhoods in `points` of `at`
    /// reaching at least `needed`.
    void check_serves(std::span<const Point> points, std::span<const Point> at, float needed, const char* where,
                      const char* what) const;
    /// @brief Centre `center`'s neighbours.
    /// @param center A centre, below size().
    /// @return Their indices into surface, in radius_search's order.
    std::span<const std::uint32_t> indices_of(std::size_t center) const
    {
        return std::span<const std::uint32_t>(indices).subspan(offsets[center], offsets[center + 1] - offsets[center]);
    }
    /// @brief Centre `center`'s neighbours' squared distances.
    /// @param center A centre, below size().
    /// @return Their squared distances, in the order of indices_of(center).
    std::span<const float> squared_distances_of(std::size_t center) const
    {
        return std::span<const float>(squared_distances)
            .subspan(offsets[center], offsets[center + 1] - offsets[center]);
    }
    /// @brief Centre `center`'s neighbours with squared distance < radius^2 (radius <=
    /// this->radius) into the cleared vectors, in the same order: what radius_search(centre,
    /// radius) finds.
    /// @param center A centre, below size().
    /// @param radius The smaller radius.
    /// @param indices Receives the neighbours' indices into surface.
    /// @param squared_distances Receives their squared distances.
    /// @throws mfpc::Error when `radius` is larger than this->radius (or not a number).
    void within(std::size_t center, float radius, std::vector<std::uint32_t>& indices,
                std::vector<float>& squared_distances) const;
};

/// @brief A hashed uniform grid over a cloud for the fixed-radius and k-nearest queries of the
/// descriptor kernels (normals, LRFs, SHOT).
///
/// Built once in O(n) (a radix sort by cell); points are copied in cell order so a query reads
/// contiguous memory. Exact: a radius query returns every point with squared distance < radius^2
/// (strictly, as FLANN), the k-nearest query the k smallest squared distances (ties by the lower
/// index). Squared distances are computed in float as `dx*dx + dy*dy + dz*dz`, in that order, which
/// is what FLANN (PCL's kd-tree) computes, so both agree on which points lie within a radius.
class NeighborGrid {
public:
    /// @brief Builds the grid over `points`. A few points far from the rest (strays kilometres
    /// out) are fine: only occupied cells take memory.
    /// @param points The cloud. Searches read a copy in cell order; points() is a view of the
    /// caller's points.
    /// @param cell_size The cell edge, > 0: about the query radius for radius queries; a few point
    /// spacings for kNN.
    /// @throws mfpc::Error for a cell size that is not positive and finite, 2^32 - 1 points or
    /// more, or a point not finite or more than 1e9 cells from the origin.
    NeighborGrid(std::span<const Point> points, float cell_size);

    /// @brief The cloud the grid was built over.
    /// @return A view of the caller's points, which result indices number.
    std::span<const Point> points() const { return points_; }
    /// @brief The cell edge.
    /// @return The cell size the grid was built with.
    float cell_size() const { return cell_size_; }
    /// @brief The number of points.
    /// @return points().size().
    std::size_t size() const { return points_.size(); }
    /// @brief The points of the fullest cell.
    /// @return How many points the fullest cell holds.
    std::size_t largest_cell() const;

    /// @brief Indices (into points()) and squared distances of the points within `radius` of
    /// `center` (squared distance < radius^2), written into the cleared vectors. The order is fixed
    /// (cell by cell, ascending index within a cell) but not by distance.
    /// @param center The query.
    /// @param radius The search radius.
    /// @param indices Receives the indices.
    /// @param squared_distances Receives the squared distances, in the order of `indices`.
    void radius_search(const Point& center, float radius, std::vector<std::uint32_t>& indices,
                       std::vector<float>& squared_distances) const;

    /// @brief How many points radius_search reads around `center` (those of the cells its search
    /// spans): a bound of how many it finds, for the cost of the row lookups alone.
    /// @param center The query.
    /// @param radius The search radius.
    /// @return The number of candidates radius_search would test.
    std::size_t candidate_count(const Point& center, float radius) const;

    /// @brief radius_search around every centre, in parallel (the same result at any thread count).
    /// @param centers The centres.
    /// @param radius The search radius.
    /// @return The neighbourhoods of the centres, in the order given.
    /// @throws mfpc::Error for a radius that is not positive and finite, or 2^32 - 1 centres or more.
    Neighborhoods radius_neighborhoods(std::span<const Point> centers, float radius) const;

    /// @brief The min(k, size()) nearest points to `center`, by ascending (squared distance, index).
    /// @param center The query.
    /// @param k The number of neighbours; none for k <= 0.
    /// @param indices Receives the indices (cleared first).
    /// @param squared_distances Receives the squared distances (cleared first).
    /// @throws mfpc::Error for a centre that is not finite.
    void knn_search(const Point& center, int k, std::vector<std::uint32_t>& indices,
                    std::vector<float>& squared_distances) const;

    /// @brief knn_search for many queries at once, with the same results: queries that share a
    /// cell share the gathering of their candidates (the 3x3x3 cells around it), which is most of
    /// the cost of a small-k query.
    /// @param queries The queries.
    /// @param k The number of neighbours per query.
    /// @param indices Receives min(k, size()) entries per query, query after query.
    /// @param squared_distances Receives the squared distances, as `indices`.
    /// @throws mfpc::Error for spans that do not hold min(k, size()) entries per query, or a query
    /// that is not finite.
    void knn_search_batch(std::span<const Point> queries, int k, std::span<std::uint32_t> indices,
                          std::span<float> squared_distances) const;

    /// @brief The nearest point within `radius` of `center` (squared distance < radius^2; ties: the
    /// lower index).
    /// @param center The query.
    /// @param radius The search radius.
    /// @param index Receives the point's index when one is found.
    /// @param squared_distance Receives its squared distance when one is found.
    /// @return Whether a point was found: false when none (also for a negative radius or a centre
    /// that is not finite).
    bool nearest(const Point& center, float radius, std::uint32_t& index, float& squared_distance) const;

private:
    // Cells are sorted by (z, y, x), so the cells of one row (fixed y and z) are consecutive and so
    // are their points: a query reads one contiguous range of points per row it touches.
    struct Row {
        std::uint64_t key;         // (z - min z) * rows_per_slice_ + y - min y; empty_row when unused
        std::uint32_t cell_begin;  // range of cells_x_ / cell_begin_
        std::uint32_t cell_end;
    };
    // Cells numbered row-major (x fastest) from the grid's minimum cell: sorting by it orders
    // cells by (z, y, x), so each row of cells is one run. Only when dense_keys_ (the numbers fit).
    std::uint64_t cell_key(const Eigen::Vector3i& cell) const
    {
        const Eigen::Vector3i d = cell - min_cell_;
        return (std::uint64_t(d.z()) * rows_per_slice_ + std::uint64_t(d.y())) * row_length_ + std::uint64_t(d.x());
    }
    // A number of a cell within min_cell_..max_cell_ that orders cells as cell_key does: cell_key
    // itself when the numbers fit, else the place of an occupied cell (all ones for an empty one).
    std::uint64_t group_key(const Eigen::Vector3i& cell) const;
    const Row* find_row(int y, int z) const;
    // The cells radius_search reads around `center`: lo..hi, within the occupied cells and one
    // beyond. False when there are none (or the centre or radius is not a number).
    bool search_box(const Point& center, float radius, Eigen::Vector3i& lo, Eigen::Vector3i& hi) const;
    // Points of row (y, z) whose cells lie in x0..x1: the range [begin, end) of ordered_points_.
    bool row_range(int y, int z, int x0, int x1, std::uint32_t& begin, std::uint32_t& end) const;
    // The same in a row already found (none when null, or when x1 < x0).
    bool cells_range(const Row* row, int x0, int x1, std::uint32_t& begin, std::uint32_t& end) const;
    // Calls visit(begin, end) for the point ranges of search_box's cells, row by row.
    template <class Visit>
    void for_each_search_range(const Point& center, float radius, Visit&& visit) const;
    // Calls visit(begin, end) for the point ranges of the cells at Chebyshev distance `ring` from
    // cell c: rows on the shell's faces whole, the others at their two ends.
    template <class Visit>
    void for_each_shell_range(const Eigen::Vector3i& c, int ring, Visit&& visit) const;
    // Every point closer to `center` than this lies in the (2 ring + 1)^3 block around cell c.
    float shell_margin(const Point& center, const Eigen::Vector3i& c, int ring) const;

    std::span<const Point> points_;
    float cell_size_;
    float inverse_cell_;
    Eigen::Vector3i min_cell_ = Eigen::Vector3i::Zero();
    Eigen::Vector3i max_cell_ = Eigen::Vector3i::Zero();
    std::uint64_t row_length_ = 1;      // cells along x, min to max
    std::uint64_t rows_per_slice_ = 1;  // rows along y
    bool dense_keys_ = true;            // cell_key numbers every cell of the extent in 64 bits
    std::vector<Point> ordered_points_;          // points in cell order
    std::vector<std::uint32_t> ordered_indices_;  // their indices into points_
    std::vector<std::int32_t> cell_x_;            // x of each occupied cell, in cell order
    std::vector<std::uint32_t> cell_begin_;       // first point of each cell, plus the end
    std::vector<Row> rows_;                       // open addressing, power-of-two size
    std::uint64_t row_mask_ = 0;
    int row_shift_ = 64;
};

}  // namespace mfpc
