#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

// The radius neighbourhoods of many centres, packed one after another: centre i's neighbours are
// entries [offsets[i], offsets[i + 1]) of indices and squared_distances, in radius_search's order.
// Kernels that each need a support of at most `radius` around the same centres (the LRF and SHOT
// of the keypoints) read them here instead of each searching again.
struct Neighborhoods {
    std::span<const Point> surface;  // the searched grid's points, which indices number
    std::vector<Point> centers;
    float radius = 0.0f;
    std::vector<std::size_t> offsets{0};
    std::vector<std::uint32_t> indices;
    std::vector<float> squared_distances;

    std::size_t size() const { return offsets.size() - 1; }
    // Whether these are neighbourhoods in `points` of exactly `at` (bit for bit): what a kernel
    // given them in place of its own searches must check.
    bool is_of(std::span<const Point> points, std::span<const Point> at) const;
    // Throws mfpc::Error (naming `where`) unless these are neighbourhoods in `points` of `at`
    // reaching at least `needed`: the check of a kernel given them, for `what` it computes.
    void check_serves(std::span<const Point> points, std::span<const Point> at, float needed, const char* where,
                      const char* what) const;
    std::span<const std::uint32_t> indices_of(std::size_t center) const
    {
        return std::span<const std::uint32_t>(indices).subspan(offsets[center], offsets[center + 1] - offsets[center]);
    }
    std::span<const float> squared_distances_of(std::size_t center) const
    {
        return std::span<const float>(squared_distances)
            .subspan(offsets[center], offsets[center + 1] - offsets[center]);
    }
    // Centre i's neighbours with squared distance < radius^2 (radius <= this->radius) into the
    // cleared vectors, in the same order: what radius_search(centre, radius) finds.
    void within(std::size_t center, float radius, std::vector<std::uint32_t>& indices,
                std::vector<float>& squared_distances) const;
};

// A hashed uniform grid over a cloud for the fixed-radius and k-nearest queries of the descriptor
// kernels (normals, LRFs, SHOT). Built once in O(n) (a radix sort by cell); points are copied in
// cell order so a query reads contiguous memory. Exact: a radius query returns every point with squared distance
// < radius^2 (strictly, as FLANN), the k-nearest query the k smallest squared distances (ties by
// the lower index).
// Squared distances are computed in float as dx*dx + dy*dy + dz*dz, in that order, which is what
// FLANN (PCL's kd-tree) computes, so both agree on which points lie within a radius.
class NeighborGrid {
public:
    // `cell_size` > 0: about the query radius for radius queries; a few point spacings for kNN.
    // Throws mfpc::Error for a point not finite or more than 1e9 cells from the origin. A few
    // points far from the rest (strays kilometres out) are fine: only occupied cells take memory.
    NeighborGrid(std::span<const Point> points, float cell_size);

    std::span<const Point> points() const { return points_; }
    float cell_size() const { return cell_size_; }
    std::size_t size() const { return points_.size(); }
    std::size_t largest_cell() const;  // the points of the fullest cell

    // Indices (into points()) and squared distances of the points within `radius` of `center`,
    // written into the cleared vectors. The order is fixed (cell by cell, ascending index within
    // a cell) but not by distance.
    void radius_search(const Point& center, float radius, std::vector<std::uint32_t>& indices,
                       std::vector<float>& squared_distances) const;

    // How many points radius_search reads around `center` (those of the cells its search spans):
    // a bound of how many it finds, for the cost of the row lookups alone.
    std::size_t candidate_count(const Point& center, float radius) const;

    // radius_search around every centre, in parallel (the same result at any thread count).
    // Throws mfpc::Error for a radius that is not positive and finite.
    Neighborhoods radius_neighborhoods(std::span<const Point> centers, float radius) const;

    // The min(k, size()) nearest points to `center`, by ascending (squared distance, index).
    // Throws mfpc::Error for a centre that is not finite (so does knn_search_batch).
    void knn_search(const Point& center, int k, std::vector<std::uint32_t>& indices,
                    std::vector<float>& squared_distances) const;

    // knn_search for many queries at once, with the same results: queries that share a cell share
    // the gathering of their candidates (the 3x3x3 cells around it), which is most of the cost of
    // a small-k query. Writes min(k, size()) entries per query, query after query.
    void knn_search_batch(std::span<const Point> queries, int k, std::span<std::uint32_t> indices,
                          std::span<float> squared_distances) const;

    // The nearest point within `radius` of `center` (ties: the lower index); false when none.
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
