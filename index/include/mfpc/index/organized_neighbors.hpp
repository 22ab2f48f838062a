#pragma once

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

// Exact k-nearest and nearest-within-a-radius search over an organized cloud (a depth image), for
// normal estimation and ICP on sensor clouds. On a Kinect view the distance to the 10th neighbour
// ranges from 2 mm to over 14 mm (the oblique floor), so no grid cell suits every query; the image
// does: the candidates are the points of the (2w+1)^2 pixels around the query's pixel. They hold
// the answer when it lies closer than any point outside the window can: such a point projects w+1
// pixels away or more, so it lies beyond one of four planes through the sensor, whose distance from
// the query bounds it (the camera's fit residual is taken off the window). Queries the bound cannot
// settle try windows twice as wide, within a budget of a few pixels per cloud point for a search;
// the rest go to a NeighborGrid over the cloud, built on first need. The results are
// NeighborGrid's, bit for bit.
class OrganizedNeighbors {
public:
    // The cloud's points are referred to, not copied: they must outlive this and stay unchanged.
    // `camera` fitted to the cloud (fit_camera: the bounds take its residual off the windows, so a
    // camera whose max_residual understates how far points project from their pixels gives wrong
    // answers); `window` the first k-nearest window's half width; `fallback_cell` the cell of the
    // grid for what the windows cannot settle. Throws mfpc::Error for a cloud that is not
    // organized on the camera's grid, a point not finite or at z <= 0, two points on one pixel,
    // or a point more than 5e8 of the fallback grid's cells from the sensor.
    OrganizedNeighbors(const PointCloud& cloud, const Camera& camera, int window = 3, float fallback_cell = 0.005f);
    OrganizedNeighbors(PointCloud&&, const Camera&, int = 3, float = 0.005f) = delete;
    ~OrganizedNeighbors();
    // A moved-from object may only be destroyed or assigned to; its searches throw.
    OrganizedNeighbors(OrganizedNeighbors&&) noexcept;
    OrganizedNeighbors& operator=(OrganizedNeighbors&&) noexcept;

    std::span<const Point> points() const { return points_; }
    std::size_t size() const { return points_.size(); }
    const Camera& camera() const { return camera_; }

    // As NeighborGrid::knn_search_batch: the min(k, size) nearest points of each query, by
    // ascending (squared distance, index).
    void knn_search_batch(std::span<const Point> queries, int k, std::span<std::uint32_t> indices,
                          std::span<float> squared_distances) const;

    static constexpr std::uint32_t no_point = 0xffffffffu;
    // As NeighborGrid::nearest for each query: the nearest point with squared distance < radius^2
    // (the lower index on a tie), or no_point (and its squared distance left alone) when none.
    void nearest_batch(std::span<const Point> queries, float radius, std::span<std::uint32_t> indices,
                       std::span<float> squared_distances) const;

    // Whether the fallback grid has been built: false while the windows have settled every query.
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
    // The pixel a query projects to; false when off the image (or behind the sensor, or not finite).
    bool pixel_of(const Point& center, long& u, long& v) const;
    // Whether the stage's whole window around pixel (u, v) lies in the image.
    bool inside(const Stage& stage, long u, long v) const;
    // A lower bound of the squared distance from the query to any point outside the window.
    double outside_bound_squared(const Stage& stage, const Point& center) const;
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
    // The same for the nearest point within `radius`.
    void nearest_window(const Stage& stage, std::span<const Point> queries, std::span<const std::uint32_t> open,
                        float radius, std::span<std::uint32_t> indices, std::span<float> squared_distances,
                        std::span<std::uint8_t> settled) const;
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
    std::vector<Stage> nearest_stages_;  // nearest's windows
    struct Fallback;
    std::unique_ptr<Fallback> fallback_;
};

}  // namespace mfpc
