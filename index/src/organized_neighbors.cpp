#include "mfpc/index/organized_neighbors.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <string>
#include <utility>

#include <Eigen/Core>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "mfpc/core/error.hpp"
#include "nearest_candidates.hpp"

namespace mfpc {
namespace {

// The relative margin between a window's bound and a distance that it settles: far above the float
// rounding of squared distances (a few 1e-7) and of a fitted camera's residual, so that a point
// outside the window that is as near as the answer (a tie, which the lower index may win) or
// nearer by a rounding error leaves the query to a wider window.
constexpr double bound_margin = 1e-4;

}  // namespace

struct OrganizedNeighbors::Fallback {
    std::once_flag once;
    std::unique_ptr<NeighborGrid> grid;
    std::atomic<bool> built{false};
};

OrganizedNeighbors::OrganizedNeighbors(const PointCloud& cloud, const Camera& camera, int window, float fallback_cell)
    : points_(cloud.points), camera_(camera), fallback_cell_(fallback_cell), fallback_(std::make_unique<Fallback>())
{
    if (!cloud.organized() || cloud.width != camera.width || cloud.height != camera.height)
        throw Error("organized neighbours", "the cloud is not organized on the camera's " +
                                                std::to_string(camera.width) + " x " + std::to_string(camera.height) +
                                                " grid");
    if (window < 1) throw Error("organized neighbours", "the window must be at least 1 pixel");
    if (!(camera.fx > 0.0f) || !(camera.fy > 0.0f) || !std::isfinite(camera.fx) || !std::isfinite(camera.fy) ||
        !std::isfinite(camera.cx) || !std::isfinite(camera.cy) || !(camera.max_residual >= 0.0f) ||
        !std::isfinite(camera.max_residual))
        throw Error("organized neighbours", "the camera's focal lengths, centre and residual must be finite, the "
                                            "focal lengths positive");
    if (!(fallback_cell > 0.0f) || !std::isfinite(fallback_cell))
        throw Error("organized neighbours", "the fallback grid's cell must be a positive number");
    // What the window bounds and the fallback grid rely on, checked here rather than met as a
    // wrong answer or as an error in the middle of some later search: every point in front of the
    // sensor, one point per pixel, and an extent the grid's cells can number.
    pixels_.assign(cloud.source_size(), -1);
    Eigen::Array3f low = Eigen::Array3f::Constant(std::numeric_limits<float>::infinity());
    Eigen::Array3f high = -low;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        const Point& p = cloud.points[i];
        if (!p.allFinite() || !(p.z() > 0.0f))
            throw Error("organized neighbours",
                        "point " + std::to_string(i) + " is not finite or not in front of the sensor");
        std::int32_t& pixel = pixels_[cloud.source_position(i)];
        if (pixel >= 0)
            throw Error("organized neighbours", "points " + std::to_string(pixel) + " and " + std::to_string(i) +
                                                    " share a pixel");
        pixel = std::int32_t(i);
        low = low.min(p.array());
        high = high.max(p.array());
    }
    // NeighborGrid's limit (coordinates within 1e9 cells), with a margin for the floors' rounding.
    const double inverse = 1.0 / double(fallback_cell);
    if (!cloud.empty() && (low.abs().max(high.abs()).cast<double>() * inverse > 0.5e9).any())
        throw Error("organized neighbours", "a point lies more than 5e8 fallback grid cells of " +
                                                format_number(fallback_cell) + " m from the sensor; use a larger cell");
    // A k-nearest query the first window cannot settle (an oblique surface, a depth edge, a far
    // and sparse background: 8% of a Kinect view) tries a window twice as wide, which settles all
    // but 2% of those, and so on. The grid, the last resort, is far slower for such queries (its
    // cells suit the near, dense surfaces; sparse points need many shells of them), and building
    // it costs as much as the whole normal estimation of a foveated scene.
    stages_ = make_stages(window);
    // A nearest point is sought within a small radius (ICP's, an inlier's) of a point on or near
    // the surface, or of one well off it (a wrong pose's): the depth range of each tile lets that
    // search pass over the tiles of pixels too far in depth to hold an answer.
    tiles_x_ = (long(camera_.width) + tile_size - 1) / tile_size;
    tiles_y_ = (long(camera_.height) + tile_size - 1) / tile_size;
    tile_depths_.assign(std::size_t(tiles_x_ * tiles_y_), {std::numeric_limits<float>::infinity(),
                                                          -std::numeric_limits<float>::infinity()});
    for (long y = 0; y < long(camera_.height); ++y)
        for (long x = 0; x < long(camera_.width); ++x)
            if (const std::int32_t i = pixels_[std::size_t(y) * camera_.width + std::size_t(x)]; i >= 0) {
                auto& [low_z, high_z] = tile_depths_[std::size_t((y / tile_size) * tiles_x_ + x / tile_size)];
                low_z = std::min(low_z, points_[std::size_t(i)].z());
                high_z = std::max(high_z, points_[std::size_t(i)].z());
            }
}

OrganizedNeighbors::~OrganizedNeighbors() = default;
OrganizedNeighbors::OrganizedNeighbors(OrganizedNeighbors&&) noexcept = default;
OrganizedNeighbors& OrganizedNeighbors::operator=(OrganizedNeighbors&&) noexcept = default;

std::vector<OrganizedNeighbors::Stage> OrganizedNeighbors::make_stages(int first) const
{
    std::vector<Stage> stages;
    const long extent = long(std::max(camera_.width, camera_.height));
    for (long window = first;; window *= 2) {
        stages.push_back(make_stage(int(std::min<long>(window, std::numeric_limits<int>::max())), stages.size() < 2));
        if (window >= extent || window >= std::numeric_limits<int>::max() / 2) break;
    }
    return stages;
}

const NeighborGrid& OrganizedNeighbors::fallback() const
{
    if (!fallback_) throw Error("organized neighbours", "searched after being moved from");
    std::call_once(fallback_->once, [&] {
        // Isolated: the grid's parallel build must not take up a task of the caller's that needs
        // the grid too, and would wait on this very call.
        tbb::this_task_arena::isolate(
            [&] { fallback_->grid = std::make_unique<NeighborGrid>(points_, fallback_cell_); });
        fallback_->built = true;
    });
    return *fallback_->grid;
}

bool OrganizedNeighbors::built_fallback() const { return fallback_ && fallback_->built; }

bool OrganizedNeighbors::affordable(const Stage& stage, std::size_t open, std::size_t& budget) const
{
    if (!stage.offsets.empty()) return true;
    if (open > budget / stage.pixels) return false;
    budget -= open * stage.pixels;
    return true;
}

std::size_t OrganizedNeighbors::wide_budget() const
{
    // A window's pixel costs about a tenth of what a point costs the grid's build (a pixel load, a
    // point load, a distance, against a sort and a copy): at four pixels a point, a search that gives
    // up on the windows has lost well under a build. A Kinect view's wide searches (a few hundred
    // queries) stay far below it and never need the grid.
    return 4 * std::max<std::size_t>(points_.size(), 1024);
}

bool OrganizedNeighbors::pixel_of(const Point& center, long& u, long& v, long off) const
{
    if (!(center.z() > 0.0f) || !center.allFinite()) return false;
    const double x = camera_.fx * (double(center.x()) / center.z()) + camera_.cx;
    const double y = camera_.fy * (double(center.y()) / center.z()) + camera_.cy;
    // Too far off the image before rounding, so that lround never sees a value past a long.
    const double margin = double(off);
    if (!(x > -1.0 - margin && y > -1.0 - margin && x < double(camera_.width) + margin &&
          y < double(camera_.height) + margin))
        return false;
    u = std::lround(x);
    v = std::lround(y);
    return u >= -off && v >= -off && u < long(camera_.width) + off && v < long(camera_.height) + off;
}

bool OrganizedNeighbors::inside(const Stage& stage, long u, long v) const
{
    return u >= stage.reach && v >= stage.reach && u + stage.reach < long(camera_.width) &&
           v + stage.reach < long(camera_.height);
}

double OrganizedNeighbors::bound_squared(double slack, const Point& center) const
{
    // The squared distance from the query to the nearest of the planes x = (a ± δx) z and
    // y = (b ± δy) z through the sensor; every point projecting farther lies beyond one of them.
    if (!(slack > 0.0)) return 0.0;
    const double z = center.z();
    const double a = std::abs(double(center.x()) / z), b = std::abs(double(center.y()) / z);
    const double delta_x = slack / camera_.fx, delta_y = slack / camera_.fy;
    return z * z * std::min(delta_x * delta_x / (1.0 + (a + delta_x) * (a + delta_x)),
                            delta_y * delta_y / (1.0 + (b + delta_y) * (b + delta_y)));
}

long OrganizedNeighbors::reach_beyond(double target, const Point& center, long cap) const
{
    // The bound grows with the slack toward z^2: s = delta^2 / (1 + (a + delta)^2) solved for the
    // plane's angle delta on each axis gives the reach, then the bound itself confirms it (should
    // the closed form's rounding fall short, a pixel more).
    const double z = center.z();
    const double s = target / ((1.0 - bound_margin) * z * z);
    if (!(s < 1.0)) return cap + 1;
    auto reach_on = [&](double a, double focal) {
        const double delta = (s * a + std::sqrt(s * s * a * a + (1.0 - s) * s * (1.0 + a * a))) / (1.0 - s);
        return delta * focal - 0.5 + double(camera_.max_residual);
    };
    const double estimate = std::max(reach_on(std::abs(double(center.x()) / z), camera_.fx),
                                     reach_on(std::abs(double(center.y()) / z), camera_.fy));
    if (!(estimate < double(cap))) return cap + 1;
    long reach = std::max(0L, long(std::ceil(estimate)));
    while (reach <= cap && !(target < bound_squared(double(reach) + 0.5 - double(camera_.max_residual), center) *
                                          (1.0 - bound_margin)))
        ++reach;
    return reach;
}

OrganizedNeighbors::Stage OrganizedNeighbors::make_stage(int window, bool listed) const
{
    // Offsets past the image's extent never land on a pixel: a window wider than the image visits
    // the whole image, and needs no more offsets (nor a product that overflows).
    // A point outside the window projects at least window + 1 pixels from the query's pixel, the
    // query at most half a pixel from it, the point at most max_residual from its own.
    Stage stage;
    stage.reach = std::min<long>(window, long(std::max(camera_.width, camera_.height)));
    stage.slack = double(window) + 0.5 - double(camera_.max_residual);
    stage.whole = stage.reach + 1 >= long(std::max(camera_.width, camera_.height));
    // The most pixels one window reads: clipped to the image.
    stage.pixels = std::size_t(std::min<long>(2 * stage.reach + 1, long(camera_.width))) *
                   std::size_t(std::min<long>(2 * stage.reach + 1, long(camera_.height)));
    if (!listed) return stage;
    for (long dy = -stage.reach; dy <= stage.reach; ++dy)
        for (long dx = -stage.reach; dx <= stage.reach; ++dx) stage.offsets.emplace_back(int(dx), int(dy));
    std::stable_sort(stage.offsets.begin(), stage.offsets.end(), [](const auto& a, const auto& b) {
        return long(a.first) * a.first + long(a.second) * a.second < long(b.first) * b.first + long(b.second) * b.second;
    });
    for (const auto& [dx, dy] : stage.offsets) stage.steps.push_back(std::ptrdiff_t(dy) * std::ptrdiff_t(camera_.width) + dx);
    return stage;
}

template <class Visit>
void OrganizedNeighbors::visit_window(const Stage& stage, long u, long v, Visit&& visit) const
{
    if (stage.offsets.empty()) {  // a wide window: row by row, clipped to the image
        const long x0 = std::max(0L, u - stage.reach), x1 = std::min(long(camera_.width) - 1, u + stage.reach);
        const long y0 = std::max(0L, v - stage.reach), y1 = std::min(long(camera_.height) - 1, v + stage.reach);
        for (long y = y0; y <= y1; ++y) {
            const std::int32_t* row = pixels_.data() + std::size_t(y) * camera_.width;
            for (long x = x0; x <= x1; ++x)
                if (row[x] >= 0) visit(row[x]);
        }
    } else if (inside(stage, u, v)) {  // no pixel needs a bounds check
        const std::int32_t* centre_pixel = pixels_.data() + std::size_t(v) * camera_.width + std::size_t(u);
        for (const std::ptrdiff_t step : stage.steps)
            if (centre_pixel[step] >= 0) visit(centre_pixel[step]);
    } else {
        for (const auto& [ox, oy] : stage.offsets) {
            const long x = u + ox, y = v + oy;
            if (x < 0 || y < 0 || x >= long(camera_.width) || y >= long(camera_.height)) continue;
            const std::int32_t i = pixels_[std::size_t(y) * camera_.width + std::size_t(x)];
            if (i >= 0) visit(i);
        }
    }
}

template <class Search>
void OrganizedNeighbors::settle(const std::vector<Stage>& stages, std::size_t query_count,
                                std::vector<std::uint32_t>& open, Search&& search) const
{
    std::vector<std::uint8_t> settled(query_count, 0);
    std::size_t budget = wide_budget();
    for (const Stage& stage : stages) {
        if (open.empty()) return;
        if (stage.slack <= 0.0 && !stage.whole) continue;
        if (!affordable(stage, open.size(), budget)) return;
        search(stage, std::span<const std::uint32_t>(open), std::span<std::uint8_t>(settled));
        std::erase_if(open, [&](std::uint32_t q) { return settled[q] != 0; });
    }
}

void OrganizedNeighbors::knn_search_batch(std::span<const Point> queries, int k, std::span<std::uint32_t> indices,
                                          std::span<float> squared_distances) const
{
    const std::size_t want = k <= 0 ? 0 : std::min<std::size_t>(std::size_t(k), points_.size());
    if (indices.size() != queries.size() * want || squared_distances.size() != queries.size() * want)
        throw Error("organized neighbours", "knn_search_batch needs min(k, size) outputs per query");
    if (want == 0 || queries.empty()) return;
    detail::check_finite_queries(queries);

    std::vector<std::uint32_t> open(queries.size());
    for (std::size_t q = 0; q < queries.size(); ++q) open[q] = std::uint32_t(q);
    settle(stages_, queries.size(), open, [&](const Stage& stage, auto open_now, auto settled) {
        search_window(stage, queries, open_now, want, indices, squared_distances, settled);
    });
    if (open.empty()) return;
    std::vector<Point> rest(open.size());
    for (std::size_t r = 0; r < open.size(); ++r) rest[r] = queries[open[r]];
    std::vector<std::uint32_t> rest_indices(rest.size() * want);
    std::vector<float> rest_distances(rest.size() * want);
    fallback().knn_search_batch(rest, int(want), rest_indices, rest_distances);
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
    const long reach = stage.reach;
    const bool listed = !stage.offsets.empty();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, open.size(), 1024), [&](const auto& range) {
        // Each query's pixel, found once: the prefetches ahead need it too.
        struct Pixel {
            long u = 0, v = 0;
            bool found = false;
            bool in_image = false;  // with its whole window
        };
        std::vector<Pixel> pixels(range.size());
        for (std::size_t o = range.begin(); o < range.end(); ++o) {
            Pixel& pixel = pixels[o - range.begin()];
            pixel.found = pixel_of(queries[open[o]], pixel.u, pixel.v);
            pixel.in_image = pixel.found && inside(stage, pixel.u, pixel.v);
        }
        // The windows of a foveated cloud's queries spread over much of the image (a few MB of
        // pixels and points, past the L2 cache), and each candidate is a pixel load, then a point
        // load that depends on it: the search waited on memory. Four queries ahead, the window's
        // pixel rows are prefetched; two ahead, the points those rows hold (a row's points are
        // consecutive in the cloud, around its centre pixel's point).
        auto prefetch_pixels = [&](std::size_t at) {
            if (at >= pixels.size() || !pixels[at].in_image) return;
            const Pixel& centre = pixels[at];
            for (long y = centre.v - reach; y <= centre.v + reach; ++y) {
                const std::int32_t* row = pixels_.data() + std::size_t(y) * camera_.width + std::size_t(centre.u);
                __builtin_prefetch(row - reach);
                __builtin_prefetch(row + reach);
            }
        };
        auto prefetch_points = [&](std::size_t at) {
            if (at >= pixels.size() || !pixels[at].in_image) return;
            const Pixel& centre = pixels[at];
            for (long y = centre.v - reach; y <= centre.v + reach; ++y) {
                const std::int32_t i = pixels_[std::size_t(y) * camera_.width + std::size_t(centre.u)];
                if (i < 0) continue;
                __builtin_prefetch(points_.data() + std::max<long>(0, i - reach));
                __builtin_prefetch(points_.data() + std::min<long>(long(points_.size()) - 1, i + reach));
            }
        };

        std::vector<detail::Candidate> best;
        best.reserve(want + 1);
        std::vector<std::uint64_t> keys(stage.steps.size());
        for (std::size_t o = range.begin(); o < range.end(); ++o) {
            const std::size_t at = o - range.begin();
            if (listed) {
                prefetch_pixels(at + 4);
                prefetch_points(at + 2);
            }
            const Pixel& pixel = pixels[at];
            if (!pixel.found) continue;
            const std::size_t q = open[o];
            const Point& center = queries[q];
            best.clear();
            if (listed && pixel.in_image) {
                // The whole window lies in the image (most queries): no pixel needs a bounds check.
                // All the window's distances first, then the selection: with no branch between
                // them, the window's loads overlap, where keep_nearest's mispredicted compares
                // issued them one after another. Each candidate is packed in one integer (an empty
                // pixel the largest) and the `want` smallest are selected in place, one integer
                // compare per candidate: keep_nearest's pair compares and vector pushes made the
                // selection a third of the search.
                const std::int32_t* centre_pixel =
                    pixels_.data() + std::size_t(pixel.v) * camera_.width + std::size_t(pixel.u);
                std::size_t valid = 0;
                for (std::size_t j = 0; j < keys.size(); ++j) {
                    const std::int32_t i = centre_pixel[stage.steps[j]];
                    const float d2 = detail::squared_distance(points_[std::size_t(std::max(i, 0))], center);
                    keys[j] = i >= 0 ? detail::candidate_key(d2, std::uint32_t(i)) : ~std::uint64_t(0);
                    valid += i >= 0;
                }
                const std::size_t n = std::min(valid, want);
                if (n > 0) detail::select_smallest(keys, n);
                for (std::size_t j = 0; j < n; ++j) best.push_back(detail::candidate_of(keys[j]));
            } else {
                visit_window(stage, pixel.u, pixel.v, [&](std::int32_t i) {
                    detail::keep_nearest(best, want,
                                         {detail::squared_distance(points_[std::size_t(i)], center), std::uint32_t(i)});
                });
            }
            if (best.size() < want) continue;
            // Every point outside the window lies at least the stage's bound away: strictly inside, with
            // bound_margin, or the query goes on to a wider window, then the grid. A window over the
            // whole image has seen every point.
            if (!stage.whole &&
                !(double(best.back().first) < bound_squared(stage.slack, center) * (1.0 - bound_margin)))
                continue;
            for (std::size_t j = 0; j < want; ++j) {
                indices[q * want + j] = best[j].second;
                squared_distances[q * want + j] = best[j].first;
            }
            settled[q] = 1;
        }
    });
}

void OrganizedNeighbors::nearest_batch(std::span<const Point> queries, float radius, std::span<std::uint32_t> indices,
                                       std::span<float> squared_distances) const
{
    if (indices.size() != queries.size() || squared_distances.size() != queries.size())
        throw Error("organized neighbours", "nearest_batch needs one output per query");
    if (!fallback_) throw Error("organized neighbours", "searched after being moved from");
    std::fill(indices.begin(), indices.end(), no_point);
    if (!(radius >= 0.0f) || points_.empty() || queries.empty()) return;  // NeighborGrid::nearest finds nothing

    // A query that is not finite is near nothing (NeighborGrid::nearest says so too).
    const float radius2 = radius * radius;
    std::vector<std::uint8_t> settled(queries.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), 128), [&](const auto& range) {
        for (std::size_t q = range.begin(); q < range.end(); ++q)
            settled[q] = !queries[q].allFinite() ||
                         nearest_in_image(queries[q], radius2, indices[q], squared_distances[q]);
    });
    std::vector<std::uint32_t> open;
    for (std::size_t q = 0; q < queries.size(); ++q)
        if (!settled[q]) open.push_back(std::uint32_t(q));
    if (open.empty()) return;
    const NeighborGrid& grid = fallback();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, open.size(), 128), [&](const auto& range) {
        for (std::size_t o = range.begin(); o < range.end(); ++o) {
            const std::size_t q = open[o];
            if (!grid.nearest(queries[q], radius, indices[q], squared_distances[q])) indices[q] = no_point;
        }
    });
}

bool OrganizedNeighbors::nearest_in_image(const Point& center, float radius2, std::uint32_t& index,
                                          float& squared_distance) const
{
    // Wider windows than this (a query a few centimetres from the sensor, or a radius near its
    // depth) are the grid's: one costs up to (2 * 48 + 1)^2 pixels, a few hundred tiles.
    constexpr long nearest_reach = 48;
    // A query projecting off the image is settled too: the window about its pixel may reach into
    // the image, or, lying wholly outside, show that nothing is near it. Farther off than any
    // window reaches, it is the grid's.
    long u = 0, v = 0;
    if (!pixel_of(center, u, v, nearest_reach)) return false;
    const long width = long(camera_.width), height = long(camera_.height);

    // The least (squared distance, index) so far, packed as one integer, and the squared distance
    // a point must beat: the radius's, then the best's.
    std::uint64_t least = std::numeric_limits<std::uint64_t>::max();
    double target = radius2;
    auto visit = [&](long x0, long x1, long y0, long y1) {
        x0 = std::max(x0, 0L), y0 = std::max(y0, 0L);
        x1 = std::min(x1, width - 1), y1 = std::min(y1, height - 1);
        for (long py = y0; py <= y1; ++py) {
            const std::int32_t* row = pixels_.data() + std::size_t(py) * camera_.width;
            for (long px = x0; px <= x1; ++px) {
                const std::int32_t i = row[px];
                const float d2 = detail::squared_distance(points_[std::size_t(std::max(i, 0))], center);
                least = std::min(least, i >= 0 ? detail::candidate_key(d2, std::uint32_t(i))
                                               : std::numeric_limits<std::uint64_t>::max());
            }
        }
        const float best = detail::candidate_of(least).first;
        if (least != std::numeric_limits<std::uint64_t>::max() && best < radius2) target = std::min(target, double(best));
    };
    // The pixels about the projection first: a query on the surface has its answer there, and the
    // reach that answer needs is then a pixel or two.
    visit(u - 1, u + 1, v - 1, v + 1);
    const double slack = 0.5 - double(camera_.max_residual);
    long reach = target < bound_squared(1.0 + slack, center) * (1.0 - bound_margin)
                     ? 1
                     : reach_beyond(target, center, nearest_reach);
    if (reach > nearest_reach) return false;
    // A reach of a few pixels (a hit a few millimetres off the surface): the rings of pixels about
    // the 3 x 3, each once, the reach shrinking as the best improves.
    constexpr long pixel_rings = 3;
    if (reach > 1 && reach <= pixel_rings) {
        for (long ring = 2; ring <= reach; ++ring) {
            const double ring_target = target;
            visit(u - ring, u + ring, v - ring, v - ring);
            visit(u - ring, u + ring, v + ring, v + ring);
            visit(u - ring, u - ring, v - ring + 1, v + ring - 1);
            visit(u + ring, u + ring, v - ring + 1, v + ring - 1);
            if (target < ring_target) reach = std::min(reach, reach_beyond(target, center, nearest_reach));
        }
    } else if (reach > 1) {
        // Then the tiles about the query's, ring after ring, each tile's pixels within the reach; a
        // tile whose depths all lie farther from the query's than the target is passed over (a
        // point is at least its depth's difference away). The reach shrinks as the best improves,
        // ring by ring.
        auto floor_div = [](long a) { return a >= 0 ? a / tile_size : -((-a + tile_size - 1) / tile_size); };
        const long tile_u = floor_div(u), tile_v = floor_div(v);
        const double z = center.z();
        for (long ring = 0;; ++ring) {
            const double ring_target = target;
            const long x_low = floor_div(std::max(u - reach, 0L)), x_high = floor_div(std::min(u + reach, width - 1));
            const long y_low = floor_div(std::max(v - reach, 0L)), y_high = floor_div(std::min(v + reach, height - 1));
            if (u + reach < 0 || v + reach < 0 || u - reach >= width || v - reach >= height) break;  // off the image
            if (ring > 0 && x_low >= tile_u - ring + 1 && x_high <= tile_u + ring - 1 && y_low >= tile_v - ring + 1 &&
                y_high <= tile_v + ring - 1)
                break;  // every tile within the reach visited
            for (long ty = std::max(tile_v - ring, y_low); ty <= std::min(tile_v + ring, y_high); ++ty) {
                const bool edge_row = ty == tile_v - ring || ty == tile_v + ring;
                const long step = edge_row || ring == 0 ? 1 : 2 * ring;
                for (long tx = tile_u - ring; tx <= tile_u + ring; tx += step) {
                    if (tx < x_low || tx > x_high) continue;
                    const auto [low_z, high_z] = tile_depths_[std::size_t(ty * tiles_x_ + tx)];
                    const double dz = std::max({0.0, double(low_z) - z, z - double(high_z)});
                    if (dz * dz > target * (1.0 + bound_margin)) continue;
                    visit(std::max(tx * tile_size, u - reach), std::min(tx * tile_size + tile_size - 1, u + reach),
                          std::max(ty * tile_size, v - reach), std::min(ty * tile_size + tile_size - 1, v + reach));
                }
            }
            if (target < ring_target) reach = std::min(reach, reach_beyond(target, center, nearest_reach));
        }
    }
    const float best = detail::candidate_of(least).first;
    if (least != std::numeric_limits<std::uint64_t>::max() && best < radius2) {
        index = std::uint32_t(least);
        squared_distance = best;
    }
    return true;
}

}  // namespace mfpc
