#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include "mfpc/core/camera.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/index/organized_neighbors.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

// A synthetic depth image: a tilted floor with a box in front of it and holes, seen by a 525 px
// pinhole camera, as an organized cloud.
PointCloud synthetic_view(std::uint32_t width, std::uint32_t height, std::uint32_t seed)
{
    std::mt19937 rng(seed);
    std::normal_distribution<float> noise(0.0f, 0.002f);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    PointCloud cloud;
    cloud.width = width;
    cloud.height = height;
    for (std::uint32_t v = 0; v < height; ++v) {
        for (std::uint32_t u = 0; u < width; ++u) {
            if (unit(rng) < 0.05f) continue;  // missing returns
            const float a = (float(u) - 0.5f * float(width - 1)) / 525.0f;
            const float b = (float(v) - 0.5f * float(height - 1)) / 525.0f;
            // Floor plane y = 0.5 + 0.3 z seen obliquely; a box face at z = 0.9 in the middle.
            float z = 0.5f / std::max(b - 0.3f, 0.02f);
            z = std::min(z, 2.0f);
            if (std::abs(a) < 0.1f && std::abs(b) < 0.1f) z = 0.9f;
            z += noise(rng) * z * z;
            cloud.points.emplace_back(a * z, b * z, z);
            cloud.source_index.push_back(v * width + u);
        }
    }
    return cloud;
}

void expect_same_as_grid(const PointCloud& cloud, int k, std::size_t stride, float cell, int window = 3)
{
    const auto camera = fit_camera(cloud);
    ASSERT_TRUE(camera.has_value());
    const NeighborGrid grid(cloud.points, cell);
    const OrganizedNeighbors organized(cloud, *camera, window, cell);
    std::vector<Point> queries;
    for (std::size_t i = 0; i < cloud.size(); i += stride) queries.push_back(cloud.points[i]);
    queries.push_back(Point(0.01f, 0.02f, 0.95f));  // off the cloud, inside the image
    queries.push_back(Point(5.0f, 0.0f, 1.0f));     // outside the image
    queries.push_back(Point(0.0f, 0.0f, -1.0f));    // behind the sensor
    const std::size_t want = std::min<std::size_t>(std::size_t(k), cloud.size());
    std::vector<std::uint32_t> a(queries.size() * want), b(queries.size() * want);
    std::vector<float> da(a.size()), db(b.size());
    grid.knn_search_batch(queries, k, a, da);
    organized.knn_search_batch(queries, k, b, db);
    EXPECT_EQ(a, b);
    EXPECT_EQ(da, db);
    // A query that is not finite has no nearest points: both say so.
    for (const Point& odd : {Point(std::numeric_limits<float>::quiet_NaN(), 0.0f, 1.0f),
                             Point(0.0f, std::numeric_limits<float>::infinity(), 1.0f)}) {
        const std::vector<Point> bad = {queries[0], odd};
        std::vector<std::uint32_t> c(2 * want);
        std::vector<float> dc(c.size());
        EXPECT_THROW(grid.knn_search_batch(bad, k, c, dc), Error);
        EXPECT_THROW(organized.knn_search_batch(bad, k, c, dc), Error);
    }
}

// The depth image's nearest points against the grid's, query by query (up to the first that
// differs); returns how many queries found one.
std::size_t expect_nearest_as_grid(const NeighborGrid& grid, const OrganizedNeighbors& organized,
                                   std::span<const Point> asked, float radius)
{
    std::vector<std::uint32_t> in_image(asked.size());
    std::vector<float> image_distances(asked.size(), -1.0f);
    organized.nearest_batch(asked, radius, in_image, image_distances);
    std::size_t found = 0;
    for (std::size_t q = 0; q < asked.size() && !::testing::Test::HasFailure(); ++q) {
        std::uint32_t index = 7;
        float distance = -1.0f;
        const bool in_grid = grid.nearest(asked[q], radius, index, distance);
        EXPECT_EQ(in_grid, in_image[q] != OrganizedNeighbors::no_point)
            << "radius " << radius << " query " << asked[q].transpose();
        if (!in_grid || in_image[q] == OrganizedNeighbors::no_point) continue;
        ++found;
        EXPECT_EQ(index, in_image[q]) << "radius " << radius << " query " << asked[q].transpose();
        EXPECT_EQ(distance, image_distances[q]) << "radius " << radius << " query " << asked[q].transpose();
    }
    return found;
}

// Queries about the cloud's points, as ICP and verification ask: on the surface, a little off it
// (a model point near its scene counterpart), far off it (a miss at every radius), and the
// queries no window can take.
void expect_same_nearest_as_grid(const PointCloud& cloud, std::size_t stride, float cell, std::uint32_t seed)
{
    const auto camera = fit_camera(cloud);
    ASSERT_TRUE(camera.has_value());
    const NeighborGrid grid(cloud.points, cell);
    const OrganizedNeighbors organized(cloud, *camera, 3, cell);
    std::mt19937 rng(seed);
    std::normal_distribution<float> offset(0.0f, 1.0f);
    std::vector<Point> queries;
    for (std::size_t i = 0; i < cloud.size(); i += stride)
        for (float scale : {0.0f, 0.001f, 0.004f, 0.02f})
            queries.push_back(cloud.points[i] + scale * Point(offset(rng), offset(rng), offset(rng)));
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    for (const Point& odd : {Point(5.0f, 0.0f, 1.0f), Point(0.0f, 0.0f, -1.0f), Point(0.0f, 0.0f, 0.0f),
                             Point(nan, 0.0f, 1.0f), Point(0.0f, inf, 1.0f), Point(0.0f, 0.0f, inf),
                             Point(1e30f, 0.0f, 1e-30f), Point(0.01f, 0.02f, 0.95f)})
        queries.push_back(odd);
    std::size_t found = 0;
    auto expect_same = [&](std::span<const Point> asked, float radius) {
        found += expect_nearest_as_grid(grid, organized, asked, radius);
    };
    for (float radius : {0.0f, 0.002f, 0.005f, 0.01f, 0.05f}) expect_same(queries, radius);
    // Radii no window can settle a miss for, on a few queries: the grid's full scans are slow.
    std::vector<Point> few;
    for (std::size_t i = 0; i < queries.size(); i += std::max<std::size_t>(1, queries.size() / 50))
        few.push_back(queries[i]);
    few.insert(few.end(), queries.end() - 8, queries.end());
    for (float radius : {inf, -1.0f, nan}) expect_same(few, radius);
    EXPECT_GT(found, 2 * queries.size());  // most queries have a point within the larger radii
}

TEST(OrganizedNeighbors, SameNeighboursAsTheGridOnASyntheticView)
{
    const PointCloud cloud = synthetic_view(160, 120, 3);
    for (int k : {1, 10, 30}) expect_same_as_grid(cloud, k, 1, 0.02f);
}

TEST(OrganizedNeighbors, AWindowWiderThanTheImageVisitsTheWholeImage)
{
    // Every query is then settled in the image alone; the offsets stop at the image's extent
    // instead of growing with the window (2^30 would overflow their count).
    const PointCloud cloud = synthetic_view(24, 18, 5);
    for (int window : {23, 24, 1 << 30}) expect_same_as_grid(cloud, 8, 1, 0.02f, window);
}

TEST(OrganizedNeighbors, SameNeighboursAsTheGridOnTheRealScene)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_pair.pcd");
    expect_same_as_grid(read_cloud(path), 10, 7, 0.005f);
}

TEST(OrganizedNeighbors, SameNearestAsTheGrid)
{
    expect_same_nearest_as_grid(synthetic_view(160, 120, 3), 3, 0.02f, 1);
    expect_same_nearest_as_grid(synthetic_view(24, 18, 5), 1, 0.02f, 2);  // windows cut by the image's edges
}

TEST(OrganizedNeighbors, SameNearestAsTheGridOnTheRealScene)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_pair.pcd");
    expect_same_nearest_as_grid(read_cloud(path), 53, 0.005f, 3);
}

// Two points at the same distance from the query, either side of it on a wall facing the sensor:
// the lower index wins, in the image as in the grid.
TEST(OrganizedNeighbors, NearestBreaksATieByTheLowerIndex)
{
    PointCloud wall;
    wall.width = 41;
    wall.height = 41;
    for (std::uint32_t v = 0; v < wall.height; ++v)
        for (std::uint32_t u = 0; u < wall.width; ++u) {
            // A hole of 5 x 5 pixels around the centre, but for the pair at u = 18 and 22 of row 20.
            const bool pair = v == 20 && (u == 18 || u == 22);
            if (!pair && u >= 18 && u <= 22 && v >= 18 && v <= 22) continue;
            wall.points.emplace_back((float(u) - 20.0f) / 500.0f, (float(v) - 20.0f) / 500.0f, 1.0f);
            wall.source_index.push_back(v * wall.width + u);
        }
    const auto camera = fit_camera(wall);
    ASSERT_TRUE(camera.has_value());
    const NeighborGrid grid(wall.points, 0.005f);
    const OrganizedNeighbors organized(wall, *camera);
    // The pair, at x = -0.004 and 0.004, is equally far from (0, 0, z), and nearer than the rest.
    const std::vector<Point> queries = {Point(0.0f, 0.0f, 1.0f), Point(0.0f, 0.0f, 0.999f), Point(0.0f, 0.0f, 0.99f)};
    std::vector<std::uint32_t> in_image(queries.size());
    std::vector<float> image_distances(queries.size());
    organized.nearest_batch(queries, 0.05f, in_image, image_distances);
    for (std::size_t q = 0; q < queries.size(); ++q) {
        std::uint32_t index = 0;
        float distance = 0.0f;
        ASSERT_TRUE(grid.nearest(queries[q], 0.05f, index, distance));
        EXPECT_EQ(wall.points[index], Point(-0.004f, 0.0f, 1.0f));
        EXPECT_EQ(in_image[q], index);
        EXPECT_EQ(image_distances[q], distance);
    }
    EXPECT_FALSE(organized.built_fallback());  // the first window settled them
}

// A cloud of a few points far apart: each point's nearest others lie beyond every window the
// budget allows (only a window over the whole image would do, at a whole image per query).
PointCloud sparse_view(const PointCloud& view)
{
    PointCloud sparse;
    sparse.width = view.width;
    sparse.height = view.height;
    for (std::size_t i = 0; i < view.size(); i += 997) {
        sparse.points.push_back(view.points[i]);
        sparse.source_index.push_back(view.source_index[i]);
    }
    return sparse;
}

// Queries the windows cannot settle go to the grid, built then and only then, with the grid's
// answers; several threads may ask for it at once.
TEST(OrganizedNeighbors, BuildsTheFallbackGridOnlyWhenAWindowCannotSettle)
{
    const PointCloud view = synthetic_view(160, 120, 7);
    const auto camera = fit_camera(view);
    ASSERT_TRUE(camera.has_value());
    const PointCloud sparse = sparse_view(view);
    const NeighborGrid grid(sparse.points, 0.05f);
    {
        const OrganizedNeighbors organized(sparse, *camera, 3, 0.05f);
        EXPECT_FALSE(organized.built_fallback());
        const std::size_t k = 5;
        std::vector<std::uint32_t> a(sparse.size() * k), b(a.size());
        std::vector<float> da(a.size()), db(a.size());
        organized.knn_search_batch(sparse.points, int(k), a, da);
        grid.knn_search_batch(sparse.points, int(k), b, db);
        EXPECT_EQ(a, b);
        EXPECT_EQ(da, db);
        EXPECT_TRUE(organized.built_fallback());
    }
    // Several searches at once, each needing the grid: one builds it, the others wait for it.
    const OrganizedNeighbors organized(sparse, *camera, 3, 0.05f);
    const std::size_t k = 5;
    std::vector<std::uint32_t> expected(sparse.size() * k);
    std::vector<float> expected_distances(expected.size());
    grid.knn_search_batch(sparse.points, int(k), expected, expected_distances);
    std::vector<std::vector<std::uint32_t>> found(8, std::vector<std::uint32_t>(expected.size()));
    std::vector<std::vector<float>> distances(8, std::vector<float>(expected.size()));
    tbb::parallel_for(std::size_t(0), found.size(), [&](std::size_t t) {
        organized.knn_search_batch(sparse.points, int(k), found[t], distances[t]);
    });
    EXPECT_TRUE(organized.built_fallback());
    for (std::size_t t = 0; t < found.size(); ++t) {
        EXPECT_EQ(found[t], expected) << t;
        EXPECT_EQ(distances[t], expected_distances) << t;
    }
}

// Queries well off the surface need wide windows (the k-nearest search's past the listed two, read
// row by row; the nearest search's tiles past its 3 x 3 pixels): within the budget they settle
// there, with the grid's answers and no grid built.
TEST(OrganizedNeighbors, WideWindowsSettleWithoutTheGrid)
{
    const PointCloud view = synthetic_view(160, 120, 9);
    const auto camera = fit_camera(view);
    ASSERT_TRUE(camera.has_value());
    const NeighborGrid grid(view.points, 0.02f);
    const OrganizedNeighbors organized(view, *camera, 3, 0.02f);
    // 2 to 3 cm in front of the box face at z = 0.9 (the nearest point 10-20 pixels away).
    std::vector<Point> queries;
    for (int i = 0; i < 4; ++i) queries.push_back(Point(-0.04f + 0.02f * float(i), 0.01f, 0.88f - 0.003f * float(i)));
    std::vector<std::uint32_t> found(queries.size());
    std::vector<float> distances(queries.size());
    organized.nearest_batch(queries, 0.1f, found, distances);
    EXPECT_FALSE(organized.built_fallback());
    const std::size_t k = 20;
    std::vector<std::uint32_t> a(queries.size() * k), b(a.size());
    std::vector<float> da(a.size()), db(a.size());
    organized.knn_search_batch(queries, int(k), a, da);
    EXPECT_FALSE(organized.built_fallback());
    grid.knn_search_batch(queries, int(k), b, db);
    EXPECT_EQ(a, b);
    EXPECT_EQ(da, db);
    for (std::size_t q = 0; q < queries.size(); ++q) {
        std::uint32_t index = 0;
        float distance = 0.0f;
        ASSERT_TRUE(grid.nearest(queries[q], 0.1f, index, distance));
        EXPECT_GT(distance, 0.015f * 0.015f) << q;  // far enough to need the wide windows
        EXPECT_EQ(found[q], index);
        EXPECT_EQ(distances[q], distance);
    }
}

// What verification asks of a wrong pose: model points in front of or behind the surface by more
// than the radius (the tiles about them all too far in depth), and points just past the image's
// edges (a hypothesis cut by the frame). The image settles them all, with the grid's answers.
TEST(OrganizedNeighbors, QueriesOffTheSurfaceOrOffTheImageSettleWithoutTheGrid)
{
    const PointCloud view = synthetic_view(160, 120, 11);
    const auto camera = fit_camera(view);
    ASSERT_TRUE(camera.has_value());
    const NeighborGrid grid(view.points, 0.02f);
    const OrganizedNeighbors organized(view, *camera, 3, 0.02f);
    std::vector<Point> queries;
    for (std::size_t i = 0; i < view.size(); i += 5)
        for (float depth : {-0.03f, -0.012f, -0.004f, 0.004f, 0.012f, 0.03f})
            queries.push_back(view.points[i] * (1.0f + depth / view.points[i].z()));
    for (std::size_t i = 0; i < view.size(); ++i) {
        const std::uint32_t pixel = view.source_index[i], u = pixel % view.width, v = pixel / view.width;
        if (u != 0 && v != 0 && u + 1 != view.width && v + 1 != view.height) continue;
        // 1 to 12 pixels past the edge, outward from the image's centre.
        const Point& p = view.points[i];
        for (float pixels : {1.0f, 3.0f, 12.0f}) {
            const float step = pixels * p.z() / 525.0f;
            queries.emplace_back(p.x() + (u == 0 ? -step : u + 1 == view.width ? step : 0.0f),
                                 p.y() + (v == 0 ? -step : v + 1 == view.height ? step : 0.0f), p.z());
        }
    }
    std::size_t found = 0;
    for (float radius : {0.005f, 0.01f, 0.02f}) found += expect_nearest_as_grid(grid, organized, queries, radius);
    // Of the 3 radii's queries, over a third found and over a third missed.
    EXPECT_GT(found, queries.size());
    EXPECT_LT(found, 2 * queries.size());
    EXPECT_FALSE(organized.built_fallback());
}

TEST(OrganizedNeighbors, RefusesAnUnorganizedCloudAndBadArguments)
{
    const PointCloud cloud = synthetic_view(40, 30, 1);
    const auto camera = fit_camera(cloud);
    ASSERT_TRUE(camera.has_value());
    PointCloud flat = cloud;
    flat.width = std::uint32_t(flat.size());
    flat.height = 1;
    flat.source_index.clear();
    EXPECT_FALSE(fit_camera(flat).has_value());
    EXPECT_THROW(OrganizedNeighbors(flat, *camera), Error);
    EXPECT_THROW(OrganizedNeighbors(cloud, *camera, 0), Error);
    EXPECT_THROW(OrganizedNeighbors(cloud, *camera, 3, 0.0f), Error);
    EXPECT_THROW(OrganizedNeighbors(cloud, *camera, 3, std::numeric_limits<float>::quiet_NaN()), Error);
    Camera flat_lens = *camera;
    flat_lens.fx = 0.0f;
    EXPECT_THROW(OrganizedNeighbors(cloud, flat_lens), Error);
    PointCloud behind = cloud;
    behind.points[5].z() = -behind.points[5].z();
    EXPECT_THROW(OrganizedNeighbors(behind, *camera), Error);
    PointCloud shared_pixel = cloud;
    shared_pixel.source_index[5] = shared_pixel.source_index[4];
    EXPECT_THROW(OrganizedNeighbors(shared_pixel, *camera), Error);
    // Points more than 5e8 fallback grid cells out, said at once.
    EXPECT_THROW(OrganizedNeighbors(cloud, *camera, 3, 1e-10f), Error);

    OrganizedNeighbors organized(cloud, *camera);
    std::vector<std::uint32_t> indices(2);
    std::vector<float> distances(2);
    EXPECT_THROW(organized.knn_search_batch(std::span(cloud.points).first(1), 1, indices, distances), Error);
    EXPECT_THROW(organized.nearest_batch(std::span(cloud.points).first(1), 0.01f, indices, distances), Error);
    const OrganizedNeighbors moved = std::move(organized);
    EXPECT_FALSE(organized.built_fallback());  // NOLINT(bugprone-use-after-move): what it promises
    EXPECT_THROW(organized.knn_search_batch(std::span(cloud.points).first(2), 1, indices, distances), Error);
    moved.nearest_batch(std::span(cloud.points).first(2), 0.01f, indices, distances);
    EXPECT_EQ(indices[0], 0u);
}

TEST(Camera, FitRecoversThePinhole)
{
    const PointCloud cloud = synthetic_view(160, 120, 5);
    const auto camera = fit_camera(cloud);
    ASSERT_TRUE(camera.has_value());
    EXPECT_NEAR(camera->fx, 525.0f, 1e-2f);
    EXPECT_NEAR(camera->fy, 525.0f, 1e-2f);
    EXPECT_NEAR(camera->cx, 79.5f, 1e-3f);
    EXPECT_NEAR(camera->cy, 59.5f, 1e-3f);
    EXPECT_LT(camera->max_residual, 1e-3f);
}

}  // namespace
}  // namespace mfpc
