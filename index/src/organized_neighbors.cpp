#include "mfpc/index/organized_neighbors.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "nearest_candidates.hpp"

namespace mfpc {

OrganizedNeighbors::OrganizedNeighbors(const PointCloud& cloud, const Camera& camera, int window)
    : points_(cloud.points), camera_(camera)
{
    if (!cloud.organized() || cloud.width != camera.width || cloud.height != camera.height)
        throw Error("organized neighbours", "the cloud is not organized on the camera's " +
                                                std::to_string(camera.width) + " x " + std::to_string(camera.height) +
                                                " grid");
    if (window < 1) throw Error("organized neighbours", "the window must be at least 1 pixel");
    pixels_.assign(cloud.source_size(), -1);
    for (std::size_t i = 0; i < cloud.size(); ++i) pixels_[cloud.source_position(i)] = std::int32_t(i);
    stages_.push_back(make_stage(window));
    // A query the window cannot settle (an oblique surface, a depth edge, a far and sparse
    // background: 8% of a Kinect view) tries a window twice as wide before the grid, which is far
    // slower there: its cells suit the near, dense surfaces, and sparse points need many shells of
    // them. Twice settles all but about 1 in 2000 on the shared scenes, and cost less than three
    // times.
    if (long(window) < long(std::max(camera.width, camera.height)))
        stages_.push_back(make_stage(int(std::min<long>(2L * window, std::numeric_limits<int>::max()))));
    // A nearest point is sought within a small radius (ICP's, an inlier's) of a point on or near
    // the surface, usually a pixel or two away: 5 x 5 pixels settle 94% of the verification's
    // queries on the shared scenes, and twice as wide most of the rest (a miss needs the window's
    // bound to pass the radius).
    nearest_stages_.push_back(make_stage(2));
    nearest_stages_.push_back(make_stage(4));
}

bool OrganizedNeighbors::pixel_of(const Point& center, long& u, long& v) const
{
    if (!(center.z() > 0.0f) || !center.allFinite()) return false;
    const double x = camera_.fx * (double(center.x()) / center.z()) + camera_.cx;
    const double y = camera_.fy * (double(center.y()) / center.z()) + camera_.cy;
    // Off the image before rounding, so that lround never sees a value past a long.
    if (!(x > -1.0 && y > -1.0 && x < double(camera_.width) && y < double(camera_.height))) return false;
    u = std::lround(x);
    v = std::lround(y);
    return u >= 0 && v >= 0 && u < long(camera_.width) && v < long(camera_.height);
}

bool OrganizedNeighbors::inside(const Stage& stage, long u, long v) const
{
    return u >= stage.reach && v >= stage.reach && u + stage.reach < long(camera_.width) &&
           v + stage.reach < long(camera_.height);
}

double OrganizedNeighbors::outside_bound_squared(const Stage& stage, const Point& center) const
{
    // The squared distance from the query to the nearest of the planes x = (a ± δx) z and
    // y = (b ± δy) z through the sensor; every point outside the window lies beyond one of them.
    const double z = center.z();
    const double a = std::abs(double(center.x()) / z), b = std::abs(double(center.y()) / z);
    const double delta_x = stage.slack / camera_.fx, delta_y = stage.slack / camera_.fy;
    return z * z * std::min(delta_x * delta_x / (1.0 + (a + delta_x) * (a + delta_x)),
                            delta_y * delta_y / (1.0 + (b + delta_y) * (b + delta_y)));
}

OrganizedNeighbors::Stage OrganizedNeighbors::make_stage(int window) const
{
    // Offsets past the image's extent never land on a pixel: a window wider than the image visits
    // the whole image, and needs no more offsets (nor a product that overflows).
    // A point outside the window projects at least window + 1 pixels from the query's pixel, the
    // query at most half a pixel from it, the point at most max_residual from its own.
    Stage stage{window, {}, {}, std::min<long>(window, long(std::max(camera_.width, camera_.height))),
                double(window) + 0.5 - double(camera_.max_residual)};
    for (long dy = -stage.reach; dy <= stage.reach; ++dy)
        for (long dx = -stage.reach; dx <= stage.reach; ++dx) stage.offsets.emplace_back(int(dx), int(dy));
    std::stable_sort(stage.offsets.begin(), stage.offsets.end(), [](const auto& a, const auto& b) {
        return long(a.first) * a.first + long(a.second) * a.second < long(b.first) * b.first + long(b.second) * b.second;
    });
    for (const auto& [dx, dy] : stage.offsets) stage.steps.push_back(std::ptrdiff_t(dy) * std::ptrdiff_t(camera_.width) + dx);
    return stage;
}

void OrganizedNeighbors::knn_search_batch(std::span<const Point> queries, int k, const NeighborGrid& grid,
                                          std::span<std::uint32_t> indices, std::span<float> squared_distances) const
{
    if (grid.points().data() != points_.data() || grid.size() != points_.size())
        throw Error("organized neighbours", "the grid is not over the organized cloud's points");
    const std::size_t want = k <= 0 ? 0 : std::min<std::size_t>(std::size_t(k), points_.size());
    if (indices.size() != queries.size() * want || squared_distances.size() != queries.size() * want)
        throw Error("organized neighbours", "knn_search_batch needs min(k, size) outputs per query");
    if (want == 0 || queries.empty()) return;

    // Queries still to settle, stage after stage.
    std::vector<std::uint32_t> open(queries.size());
    for (std::size_t q = 0; q < queries.size(); ++q) open[q] = std::uint32_t(q);
    std::vector<std::uint8_t> settled(queries.size(), 0);
    for (const Stage& stage : stages_) {
        search_window(stage, queries, open, want, indices, squared_distances, settled);
        std::erase_if(open, [&](std::uint32_t q) { return settled[q] != 0; });
        if (open.empty()) return;
    }
    std::vector<Point> rest(open.size());
    for (std::size_t r = 0; r < open.size(); ++r) rest[r] = queries[open[r]];
    std::vector<std::uint32_t> rest_indices(rest.size() * want);
    std::vector<float> rest_distances(rest.size() * want);
    grid.knn_search_batch(rest, int(want), rest_indices, rest_distances);
    for (std::size_t r = 0; r < rest.size(); ++r) {
        std::copy_n(rest_indices.begin() + std::ptrdiff_t(r * want), want, indices.begin() + std::ptrdiff_t(open[r] * want));
        std::copy_n(rest_distances.begin() + std::ptrdiff_t(r * want), want,
                    squared_distances.begin() + std::ptrdiff_t(open[r] * want));
    }
}

void OrganizedNeighbors::search_window(const Stage& stage, std::span<const Point> queries,
                                       std::span<const std::uint32_t> open, std::size_t want,
                                       std::span<std::uint32_t> indices, std::span<float> squared_distances,
                                       std::span<std::uint8_t> settled) const
{
    if (stage.slack <= 0.0) return;

    const long reach = stage.reach;
    auto inside = [&](long u, long v) { return this->inside(stage, u, v); };
    // The windows of a foveated cloud's queries spread over much of the image (a few MB of pixels
    // and points, past the L2 cache), and each candidate is a pixel load, then a point load that
    // depends on it: the search waited on memory. Four queries ahead, the window's pixel rows are
    // prefetched; two ahead, the points those rows hold (a row's points are consecutive in the
    // cloud, around its centre pixel's point).
    auto prefetch_pixels = [&](std::size_t o) {
        long u, v;
        if (o >= open.size() || !pixel_of(queries[open[o]], u, v) || !inside(u, v)) return;
        for (long y = v - reach; y <= v + reach; ++y) {
            const std::int32_t* row = pixels_.data() + std::size_t(y) * camera_.width + std::size_t(u);
            __builtin_prefetch(row - reach);
            __builtin_prefetch(row + reach);
        }
    };
    auto prefetch_points = [&](std::size_t o) {
        long u, v;
        if (o >= open.size() || !pixel_of(queries[open[o]], u, v) || !inside(u, v)) return;
        for (long y = v - reach; y <= v + reach; ++y) {
            const std::int32_t i = pixels_[std::size_t(y) * camera_.width + std::size_t(u)];
            if (i < 0) continue;
            __builtin_prefetch(points_.data() + std::max<long>(0, i - reach));
            __builtin_prefetch(points_.data() + std::min<long>(long(points_.size()) - 1, i + reach));
        }
    };

    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, open.size(), 1024), [&](const auto& range) {
        std::vector<detail::Candidate> best;
        best.reserve(want + 1);
        std::vector<std::int32_t> window_points(stage.steps.size());
        std::vector<float> window_distances(stage.steps.size());
        for (std::size_t o = range.begin(); o < range.end(); ++o) {
            prefetch_pixels(o + 4);
            prefetch_points(o + 2);
            const std::size_t q = open[o];
            const Point& center = queries[q];
            long u, v;
            if (!pixel_of(center, u, v)) continue;
            best.clear();
            auto consider = [&](std::int32_t i) {
                if (i < 0) return;
                const Point& p = points_[std::size_t(i)];
                // NeighborGrid's arithmetic, so the distances are its distances.
                const float dx = p.x() - center.x(), dy = p.y() - center.y(), dz = p.z() - center.z();
                detail::keep_nearest(best, want, {dx * dx + dy * dy + dz * dz, std::uint32_t(i)});
            };
            if (inside(u, v)) {
                // The whole window lies in the image (most queries): no pixel needs a bounds check.
                // All the window's distances first, then the selection: with no branch between
                // them, the window's loads overlap, where keep_nearest's mispredicted compares
                // issued them one after another.
                const std::int32_t* centre_pixel = pixels_.data() + std::size_t(v) * camera_.width + std::size_t(u);
                for (std::size_t j = 0; j < stage.steps.size(); ++j) {
                    const std::int32_t i = centre_pixel[stage.steps[j]];
                    const Point& p = points_[std::size_t(std::max(i, 0))];
                    const float dx = p.x() - center.x(), dy = p.y() - center.y(), dz = p.z() - center.z();
                    window_points[j] = i;
                    window_distances[j] = dx * dx + dy * dy + dz * dz;
                }
                for (std::size_t j = 0; j < stage.steps.size(); ++j)
                    if (window_points[j] >= 0)
                        detail::keep_nearest(best, want, {window_distances[j], std::uint32_t(window_points[j])});
            } else {
                for (const auto& [ox, oy] : stage.offsets) {
                    const long x = u + ox, y = v + oy;
                    if (x < 0 || y < 0 || x >= long(camera_.width) || y >= long(camera_.height)) continue;
                    consider(pixels_[std::size_t(y) * camera_.width + std::size_t(x)]);
                }
            }
            if (best.size() < want) continue;
            // Every point outside the window lies at least outside_bound away: strictly inside, with a relative margin for the float distances: a tie with an
            // unseen point must go on (to a wider window, then the grid, which breaks it by index).
            if (!(double(best.back().first) < outside_bound_squared(stage, center) * (1.0 - 1e-4))) continue;
            for (std::size_t j = 0; j < want; ++j) {
                indices[q * want + j] = best[j].second;
                squared_distances[q * want + j] = best[j].first;
            }
            settled[q] = 1;
        }
    });
}

bool OrganizedNeighbors::nearest(const Point& center, float radius, const NeighborGrid& grid, std::uint32_t& index,
                                 float& squared_distance) const
{
    if (grid.points().data() != points_.data() || grid.size() != points_.size())
        throw Error("organized neighbours", "the grid is not over the organized cloud's points");
    long u, v;
    if (radius >= 0.0f && pixel_of(center, u, v)) {
        const float radius2 = radius * radius;
        for (const Stage& stage : nearest_stages_) {
            if (stage.slack <= 0.0) continue;
            // The least (squared distance, index), as one integer: squared distances are >= +0,
            // where the order of floats is that of their bits. No branch to mispredict.
            std::uint64_t least = std::numeric_limits<std::uint64_t>::max();
            auto consider = [&](std::int32_t i) {
                const Point& p = points_[std::size_t(std::max(i, 0))];
                const float dx = p.x() - center.x(), dy = p.y() - center.y(), dz = p.z() - center.z();
                const std::uint64_t key =
                    (std::uint64_t(std::bit_cast<std::uint32_t>(dx * dx + dy * dy + dz * dz)) << 32) | std::uint32_t(i);
                least = std::min(least, i < 0 ? std::numeric_limits<std::uint64_t>::max() : key);
            };
            if (inside(stage, u, v)) {  // no pixel needs a bounds check
                const std::int32_t* centre_pixel = pixels_.data() + std::size_t(v) * camera_.width + std::size_t(u);
                for (const std::ptrdiff_t step : stage.steps) consider(centre_pixel[step]);
            } else {
                for (const auto& [ox, oy] : stage.offsets) {
                    const long x = u + ox, y = v + oy;
                    if (x < 0 || y < 0 || x >= long(camera_.width) || y >= long(camera_.height)) continue;
                    consider(pixels_[std::size_t(y) * camera_.width + std::size_t(x)]);
                }
            }
            const float best = std::bit_cast<float>(std::uint32_t(least >> 32));
            const bool found = least != std::numeric_limits<std::uint64_t>::max() && best < radius2;
            // Settled when every point outside the window is farther than the window's nearest
            // (strictly: a tie goes to the lower index, which may lie outside), or, for a miss,
            // at least the radius away; with knn's margin for the float distances.
            const double limit = outside_bound_squared(stage, center) * (1.0 - 1e-4);
            if (found ? double(best) < limit : double(radius2) <= limit) {
                if (found) {
                    index = std::uint32_t(least);
                    squared_distance = best;
                }
                return found;
            }
        }
    }
    return grid.nearest(center, radius, index, squared_distance);
}

}  // namespace mfpc
