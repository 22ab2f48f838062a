#pragma once

/// @file
/// @brief OrganizedNeighbors, exact k-nearest and nearest-within-a-radius search over a depth
/// image.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <utility>
#include <vector>

#include "mfpc/core/camera.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/index/neighbor_grid.hpp"

namespace mfpc {

/// @brief Exact k-nearest and nearest-within-a-radius search over an organized cloud (a depth
/// image), for normal estimation and ICP on sensor clouds.
///
/// On a Kinect view the distance to the 10th neighbour ranges from 2 mm to over 14 mm (the oblique
/// floor), so no grid cell suits every query; the image does: the candidates are the points of the
/// (2w+1)^2 pixels around the query's pixel. They hold the answer when it lies closer than any
/// point outside the window can: such a point projects w+1 pixels away or more, so it lies beyond
/// one of four planes through the sensor, whose distance from the query bounds it (the camera's fit
/// residual is taken off the window). Queries the bound cannot settle try windows twice as wide,
/// within a budget of a few pixels per cloud point for a search; the rest go to a NeighborGrid over
/// the cloud, built on first need. A nearest-within-a-radius query reads the 3 x 3 pixels about its
/// projection (off the image too), then, as far as the radius or the best so far needs, the rings
/// of pixels around them (2 or 3 pixels out) or tiles of 8 x 8 pixels ring after ring, passing over
/// the tiles whose depths all lie too far from the query's.
/// The results are NeighborGrid's, bit for bit.
class OrganizedNeighbors {
public:
    /// @brief Prepares the search over an organized cloud. The cloud's points are referred to, not
    /// copied: they must outlive this and stay unchanged.
    /// @param cloud The organized cloud, on the camera's width x height grid.
    /// @param camera The camera fitted to the cloud (fit_camera: the bounds take its residual off
    /// the windows, so a camera whose max_residual understates how far points project from their
    /// pixels gives wrong answers).
    /// @param window The first k-nearest window's half width (pixels, at least 1).
    /// @param fallback_cell The cell of the grid for what the windows cannot settle (metres).
    /// @throws mfpc::Error for a cloud that is not organized on the camera's grid, a camera with
    /// focal lengths not positive or a centre or residual not finite, a window below 1, a fallback
    /// cell that is not positive and finite, a point not finite or at z <= 0, two points on one
    /// pixel, or a point more than 5e8 of the fallback grid's cells from the sensor.
    OrganizedNeighbors(const PointCloud& cloud, const Camera& camera, int window = 3, float fallback_cell = 0.005f);
    /// @brief Deleted: the search refers to the cloud's points, which a temporary would leave
    /// dangling.
    OrganizedNeighbors(PointCloud&&, const Camera&, int = 3, float = 0.005f) = delete;
    /// @brief Frees the windows and the fallback grid.
    ~OrganizedNeighbors();
    /// @brief Moves the search. A moved-from object may only be destroyed or assigned to; its
    /// searches throw.
    OrganizedNeighbors(OrganizedNeighbors&&) noexcept;
    /// @brief Move-assigns the search. A moved-from object may only be destroyed or assigned to;
    /// its searches throw.
    /// @return This object.
    OrganizedNeighbors& operator=(OrganizedNeighbors&&) noexcept;

    /// @brief The cloud's points.
    /// @return A view of the caller's points, which result indices number.
    std::span<const Point> points() const { return points_; }
    /// @brief The number of points.
    /// @return points().size().
    std::size_t size() const { return points_.size(); }
    /// @brief The camera the search was built with.
    /// @return The camera.
    const Camera& camera() const { return camera_; }

    /// @brief As NeighborGrid::knn_search_batch: the min(k, size) nearest points of each query, by
    /// ascending (squared distance, index).
    /// @param queries The queries.
    /// @param k The number of neighbours per query.
    /// @param indices Receives min(k, size()) entries per query, query after query.
    /// @param squared_distances Receives the squared distances, as `indices`.
    /// @throws mfpc::Error for spans that do not hold min(k, size()) entries per query, a query that
    /// is not finite, or a moved-from object.
    void knn_search_batch(std::span<const Point> queries, int k, std::span<std::uint32_t> indices,
                          std::span<float> squared_distances) const;

    /// The index nearest_batch gives a query with no point within the radius.
    static constexpr std::uint32_t no_point = 0xffffffffu;
    /// @brief As NeighborGrid::nearest for each query: the nearest point with squared distance <
    /// radius^2 (the lower index on a tie), or no_point (and its squared distance left alone) when
    /// none. A query that is not finite is near nothing.
    /// @param queries The queries.
    /// @param radius The search radius.
    /// @param indices Receives one index per query, or no_point.
    /// @param squared_distances Receives one squared distance per query where a point is found.
    /// @throws mfpc::Error for spans that do not hold one entry per query, or a moved-from object.
    void nearest_batch(std::span<const Point> queries, float radius, std::span<std::uint32_t> indices,
                       std::span<float> squared_distances) const;

    /// @brief Whether the fallback grid has been built.
    /// @return False while the windows have settled every query.
    bool built_fallback() const;

private:
    struct Stage {
        // The window's pixel offsets, nearest the centre first: near pixels hold near points, so
        // the k best fill early and most later candidates fail a single compare. Empty for the
        // wide windows past the second, which few queries reach: scanned row by row instead.
        std::vector<std::pair<int, int>> offsets;
        std::vector<std::ptrdiff_t> steps;  // the same offsets in the row-major pixel array
        long reach = 0;       // the largest offset on either axis: min(window, image extent)
        double slack = 0.0;   // pixels between the query's projection and any point outside the window
        bool whole = false;   // the window covers the image from any pixel: it sees every point
        std::size_t pixels = 0;  // the most pixels one window reads, clipped to the image
    };
    Stage make_stage(int window, bool listed) const;
    // Windows from `first` doubling until one covers the image; the first two listed.
    std::vector<Stage> make_stages(int first) const;
    // The pixel a query projects to; false when more than `off` pixels off the image (or behind the
    // sensor, or not finite).
    bool pixel_of(const Point& center, long& u, long& v, long off = 0) const;
    // Whether the stage's whole window around pixel (u, v) lies in the image.
    bool inside(const Stage& stage, long u, long v) const;
    // Calls visit(point index) for every point in the stage's window around pixel (u, v).
    template <class Visit>
    void visit_window(const Stage& stage, long u, long v, Visit&& visit) const;
    // Runs `stages` over the `open` queries while they are affordable: search(stage, open, settled)
    // marks those a stage settles. Leaves in `open` the queries still unsettled.
    template <class Search>
    void settle(const std::vector<Stage>& stages, std::size_t query_count, std::vector<std::uint32_t>& open,
                Search&& search) const;
    // Searches the stage's window around each open query for its k nearest; marks those it settles.
    void search_window(const Stage& stage, std::span<const Point> queries, std::span<const std::uint32_t> open,
                       std::size_t want, std::span<std::uint32_t> indices, std::span<float> squared_distances,
                       std::span<std::uint8_t> settled) const;
    // The squared distance from a query to the nearest of the four planes through the sensor that
    // pass `slack` pixels either side of its projection: a lower bound for any point projecting
    // farther than that: with a stage's slack, any point outside its window.
    double bound_squared(double slack, const Point& center) const;
    // The least window reach (pixels about the query's pixel) whose outside lies farther than
    // `target` (squared, with bound_margin); a reach past `cap` (or none: the target is beyond
    // every plane) gives cap + 1.
    long reach_beyond(double target, const Point& center, long cap) const;
    // The nearest point to `center` with squared distance < radius2, from the depth image alone:
    // the pixels about its projection, then rings of pixels or of tiles (those too far in depth
    // skipped, tile_depths_). False when the image cannot settle it (behind the sensor, or a window
    // wider than nearest_reach needed): the fallback grid's then.
    bool nearest_in_image(const Point& center, float radius2, std::uint32_t& index, float& squared_distance) const;
    // Whether a stage is worth running for `open` queries rather than going to the grid, within
    // what is left of a search's budget of window pixels (taken from it when so).
    bool affordable(const Stage& stage, std::size_t open, std::size_t& budget) const;
    std::size_t wide_budget() const;
    const NeighborGrid& fallback() const;

    std::span<const Point> points_;
    Camera camera_;
    float fallback_cell_;
    std::vector<std::int32_t> pixels_;   // point index per pixel, -1 where no return
    std::vector<Stage> stages_;          // k-nearest's windows
    // Each tile of tile_size x tile_size pixels' least and greatest point depth (an empty tile's:
    // +inf, -inf), row by row of tiles_x_: a point is at least its depth's difference from a query
    // away, so most tiles about a point off the surface hold nothing near it.
    static constexpr long tile_size = 8;
    long tiles_x_ = 0, tiles_y_ = 0;
    std::vector<std::pair<float, float>> tile_depths_;
    struct Fallback;
    std::unique_ptr<Fallback> fallback_;
};

}  // namespace mfpc
