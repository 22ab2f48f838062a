#include "mfpc/recognition/features.hpp"

#include <algorithm>
#include <chrono>
#include <limits>
#include <string>
#include <utility>

#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/kernels/normals.hpp"
#include "mfpc/kernels/shot.hpp"
#include "mfpc/kernels/uniform_sampling.hpp"
#include "mfpc/kernels/voxel_grid.hpp"

namespace mfpc {
namespace {

double elapsed_ms(std::chrono::steady_clock::time_point since)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

std::span<const float> Features::descriptor(std::size_t i) const
{
    return std::span<const float>(descriptors).subspan(i * shot_size, shot_size);
}

namespace {

// One search of the larger support per keypoint, which BOARD and SHOT then share. Holding every
// keypoint's support at once takes 8 bytes a neighbour: 16 MB on a Kinect scene at the default
// radii, but 2 GB with a keypoint every 2 mm and 7 GB with supports as wide as the scene. So
// unless the fullest cell says they cannot (a support spans at most 3 cells a side), each
// keypoint's candidates (the points of the cells its search reads: a bound of its support) are
// counted, and the keypoints go in batches of at most `budget` candidates. Returns where each
// batch begins, then the end. Each keypoint's frame and descriptor come from its own support, so
// batching changes no output.
std::vector<std::size_t> support_batches(const NeighborGrid& grid, std::span<const Point> keypoints, float support,
                                         std::size_t budget)
{
    std::vector<std::size_t> begins{0};
    if (double(keypoints.size()) * 27.0 * double(grid.largest_cell()) > double(budget)) {
        std::vector<std::size_t> bounds(keypoints.size());
        tbb::parallel_for(std::size_t(0), keypoints.size(),
                          [&](std::size_t i) { bounds[i] = grid.candidate_count(keypoints[i], support); });
        std::size_t held = 0;
        for (std::size_t i = 0; i < keypoints.size(); ++i) {
            if (held > 0 && held + bounds[i] > budget) {
                begins.push_back(i);
                held = 0;
            }
            held += bounds[i];
        }
    }
    begins.push_back(keypoints.size());
    return begins;
}

// describe_keypoints over either neighbour index of the normals' source.
template <class Source>
Features describe(std::span<const Point> surface, std::span<const std::uint32_t> keypoints, const Source& normal_source,
                  const FeatureParams& params, FeatureTimings* timings, std::span<const Point> orientation,
                  std::size_t support_budget)
{
    if (!orientation.empty() && orientation.size() != surface.size())
        throw Error("describe_keypoints", "the orientation normals must be one per surface point");
    if (!(params.lrf_radius > 0.0f) || !(params.shot_radius > 0.0f))
        throw Error("describe_keypoints", "the LRF and SHOT radii must be positive");
    for (std::uint32_t k : keypoints)
        if (k >= surface.size())
            throw Error("describe_keypoints", "keypoint index " + std::to_string(k) + " is outside the surface of " +
                                                  std::to_string(surface.size()) + " points");
    FeatureTimings local;
    FeatureTimings& time = timings ? *timings : local;

    auto start = std::chrono::steady_clock::now();
    const float support = std::max(params.lrf_radius, params.shot_radius);
    const NeighborGrid surface_grid(surface, support);
    std::vector<Point> keypoint_points(keypoints.size());
    for (std::size_t i = 0; i < keypoints.size(); ++i) keypoint_points[i] = surface[keypoints[i]];
    std::vector<Point> normals(surface.size(), Point::Constant(std::numeric_limits<float>::quiet_NaN()));
    std::vector<std::uint8_t> has_normal(surface.size(), 0);
    std::vector<LocalReferenceFrame> board(keypoints.size());
    std::vector<LocalReferenceFrame> shot_frames(keypoints.size());
    std::vector<float> descriptors(keypoints.size() * shot_size);
    BoardParams board_params;
    board_params.radius = params.lrf_radius;

    const std::vector<std::size_t> batch_begins =
        support_batches(surface_grid, keypoint_points, support, support_budget);
    time.normals_ms += elapsed_ms(start);

    for (std::size_t b = 0; b + 1 < batch_begins.size(); ++b) {
        start = std::chrono::steady_clock::now();
        const std::size_t begin = batch_begins[b], count = batch_begins[b + 1] - begin;
        const std::span<const Point> batch = std::span<const Point>(keypoint_points).subspan(begin, count);
        const Neighborhoods neighborhoods = surface_grid.radius_neighborhoods(batch, support);

        // Normals only where a descriptor or frame reads them, and each once: the surface points
        // within the support of some keypoint of this batch that no earlier batch needed.
        constexpr std::uint8_t wanted = 2;
        for (const std::uint32_t n : neighborhoods.indices)
            if (has_normal[n] == 0) has_normal[n] = wanted;
        std::vector<std::uint32_t> queries;
        for (std::size_t i = 0; i < surface.size(); ++i)
            if (has_normal[i] == wanted) {
                has_normal[i] = 1;
                queries.push_back(std::uint32_t(i));
            }
        std::vector<Point> query_points(queries.size());
        for (std::size_t i = 0; i < queries.size(); ++i) query_points[i] = surface[queries[i]];
        std::vector<Point> query_normals(queries.size());
        estimate_normals(query_points, normal_source, NormalParams{params.normal_k, Point::Zero()}, query_normals);
        if (!orientation.empty()) {
            std::vector<Point> reference(queries.size());
            for (std::size_t i = 0; i < queries.size(); ++i) reference[i] = orientation[queries[i]];
            orient_normals(query_normals, reference);
        }
        for (std::size_t i = 0; i < queries.size(); ++i) normals[queries[i]] = query_normals[i];
        time.normals_ms += elapsed_ms(start);

        start = std::chrono::steady_clock::now();
        board_frames(batch, surface_grid, normals, board_params, std::span(board).subspan(begin, count),
                     &neighborhoods);
        time.lrf_ms += elapsed_ms(start);

        start = std::chrono::steady_clock::now();
        shot_descriptors(batch, surface_grid, normals, ShotParams{params.shot_radius},
                         std::span(shot_frames).subspan(begin, count),
                         std::span(descriptors).subspan(begin * shot_size, count * shot_size), &neighborhoods);
        time.descriptors_ms += elapsed_ms(start);
    }

    // Invalid keypoints are dropped in place, the valid ones moved down over them: appending the
    // descriptors to a new array grew it piece by piece, and its fresh pages (4 MB on a scene)
    // cost more than the descriptors' copy.
    Features features;
    features.candidates = keypoints.size();
    std::size_t kept = 0;
    for (std::size_t i = 0; i < keypoints.size(); ++i) {
        const auto descriptor = std::span<const float>(descriptors).subspan(i * shot_size, shot_size);
        const bool valid = is_valid(board[i]) &&
                           std::all_of(descriptor.begin(), descriptor.end(), [](float v) { return std::isfinite(v); });
        if (!valid) {
            ++features.invalid;
            continue;
        }
        if (kept != i) {
            keypoint_points[kept] = keypoint_points[i];
            board[kept] = board[i];
            std::copy(descriptor.begin(), descriptor.end(), descriptors.begin() + std::ptrdiff_t(kept * shot_size));
        }
        ++kept;
    }
    keypoint_points.resize(kept);
    board.resize(kept);
    descriptors.resize(kept * shot_size);
    features.keypoints = std::move(keypoint_points);
    features.frames = std::move(board);
    features.descriptors = std::move(descriptors);
    return features;
}

}  // namespace

Features describe_keypoints(std::span<const Point> surface, std::span<const std::uint32_t> keypoints,
                            const NeighborGrid& normal_source, const FeatureParams& params, FeatureTimings* timings,
                            std::span<const Point> orientation, std::size_t support_budget)
{
    return describe(surface, keypoints, normal_source, params, timings, orientation, support_budget);
}

Features describe_keypoints(std::span<const Point> surface, std::span<const std::uint32_t> keypoints,
                            const OrganizedNeighbors& normal_source, const FeatureParams& params,
                            FeatureTimings* timings, std::span<const Point> orientation, std::size_t support_budget)
{
    return describe(surface, keypoints, normal_source, params, timings, orientation, support_budget);
}

Features describe_at_resolution(std::span<const Point> cloud, const FeatureParams& params, FeatureTimings* timings,
                                std::span<const Point> orientation, std::size_t* resampled_points)
{
    if (!(params.resolution > 0.0f)) throw Error("describe_at_resolution", "the resolution must be positive");
    if (!orientation.empty() && orientation.size() != cloud.size())
        throw Error("describe_at_resolution", "the orientation normals must be one per cloud point");
    const auto start = std::chrono::steady_clock::now();
    const VoxelGrid grid = voxel_grid(cloud, params.resolution);
    if (resampled_points) *resampled_points = grid.centroids.size();
    std::vector<Point> voxel_orientation;
    for (const std::uint32_t i : orientation.empty() ? std::span<const std::uint32_t>() : std::span(grid.first))
        voxel_orientation.push_back(orientation[i]);
    // Cells of 3 voxels: the 30 nearest of a resampled surface lie within about 1.5 cm, so the
    // k-nearest search mostly reads one ring of cells (2 voxels gave 20% more normals time).
    const NeighborGrid neighbours(grid.centroids, 3.0f * params.resolution);
    const std::vector<std::uint32_t> keypoints = uniform_sampling(grid.centroids, params.keypoint_radius);
    if (timings) timings->normals_ms += elapsed_ms(start);
    return describe_keypoints(grid.centroids, keypoints, neighbours, params, timings, voxel_orientation);
}

}  // namespace mfpc
