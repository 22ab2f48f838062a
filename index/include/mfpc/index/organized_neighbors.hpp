#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "mfpc/core/camera.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/index/neighbor_grid.hpp"

namespace mfpc {

// Exact k-nearest and nearest-within-a-radius search over an organized cloud (a depth image), for
// normal estimation and ICP on sensor clouds. On a Kinect view the distance to the 10th neighbour ranges from 2 mm to over 14 mm (the
// oblique floor), so no grid cell suits every query; the image does: the candidates are the points
// of the (2w+1)^2 pixels around the query's pixel. They are the true k nearest when the k-th lies
// closer than any point outside the window can: such a point projects w+1 pixels away or more, so
// it lies beyond one of four planes through the sensor, whose distance from the query bounds it
// (the camera's fit residual is taken off the window). Queries the bound cannot settle try a window
// twice as wide, then go to the grid. The results are NeighborGrid::knn_search's, bit for bit.
class OrganizedNeighbors {
public:
    // `cloud` must be the cloud the grid passed to knn_search_batch was built over (same points,
    // same order); `camera` fitted to it (fit_camera).
    OrganizedNeighbors(const PointCloud& cloud, const Camera& camera, int window = 3);

    // As NeighborGrid::knn_search_batch: min(k, size) entries per query.
    void knn_search_batch(std::span<const Point> queries, int k, const NeighborGrid& grid,
                          std::span<std::uint32_t> indices, std::span<float> squared_distances) const;

    // As NeighborGrid::nearest (the nearest point with squared distance < radius^2, the lower
    // index on a tie; false when there is none), the same answers: a window of 5 x 5 pixels, then
    // 9 x 9, then the grid, settling as the k-nearest search does. `grid` as for knn_search_batch.
    bool nearest(const Point& center, float radius, const NeighborGrid& grid, std::uint32_t& index,
                 float& squared_distance) const;

private:
    struct Stage {
        int window;  // as asked; offsets stop at the image's extent, which covers the same pixels
        // The window's pixel offsets, nearest the centre first: near pixels hold near points, so
        // the k best fill early and most later candidates fail a single compare.
        std::vector<std::pair<int, int>> offsets;
        std::vector<std::ptrdiff_t> steps;  // the same offsets in the row-major pixel array
        long reach = 0;                     // the largest offset on either axis: min(window, image extent)
        double slack = 0.0;  // pixels between the query's projection and any point outside the window
    };
    Stage make_stage(int window) const;
    // The pixel a query projects to; false when off the image (or behind the sensor, or not finite).
    bool pixel_of(const Point& center, long& u, long& v) const;
    // Whether the stage's whole window around pixel (u, v) lies in the image.
    bool inside(const Stage& stage, long u, long v) const;
    // A lower bound of the squared distance from the query to any point outside the window.
    double outside_bound_squared(const Stage& stage, const Point& center) const;
    // Searches the stage's window around each open query; marks those it settles.
    void search_window(const Stage& stage, std::span<const Point> queries, std::span<const std::uint32_t> open,
                       std::size_t want, std::span<std::uint32_t> indices, std::span<float> squared_distances,
                       std::span<std::uint8_t> settled) const;

    std::span<const Point> points_;
    Camera camera_;
    std::vector<std::int32_t> pixels_;  // point index per pixel, -1 where no return
    std::vector<Stage> stages_;         // the window, then a wider one
    std::vector<Stage> nearest_stages_;  // nearest's windows
};

}  // namespace mfpc
