#include <algorithm>
#include <limits>
#include <random>
#include <span>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "mfpc/core/error.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "random_clouds.hpp"

namespace mfpc {
namespace {

float brute_distance(const Point& a, const Point& b)
{
    const float dx = a.x() - b.x(), dy = a.y() - b.y(), dz = a.z() - b.z();
    return dx * dx + dy * dy + dz * dz;
}

// NeighborGrid::nearest against a scan of every point: the nearest within the radius, the lower
// index of equals (a strict compare in index order keeps the first).
void expect_nearest_as_brute_force(const NeighborGrid& grid, std::span<const Point> points, const Point& center,
                                   float radius, int query)
{
    std::uint32_t expected = 0;
    float expected_d2 = radius * radius;
    bool expected_found = false;
    for (std::uint32_t i = 0; i < points.size(); ++i) {
        const float d2 = brute_distance(points[i], center);
        if (d2 < expected_d2) {
            expected_found = true;
            expected_d2 = d2;
            expected = i;
        }
    }
    std::uint32_t index = 0;
    float d2 = 0.0f;
    ASSERT_EQ(grid.nearest(center, radius, index, d2), expected_found) << "query " << query;
    if (expected_found) {
        EXPECT_EQ(index, expected) << "query " << query;
        EXPECT_EQ(d2, expected_d2) << "query " << query;
    }
}

TEST(NeighborGrid, RadiusSearchFindsExactlyThePointsWithinTheRadius)
{
    const auto points = test::random_points(20000, 7);
    for (float cell : {0.03f, 0.1f, 0.4f}) {
        const NeighborGrid grid(points, cell);
        std::vector<std::uint32_t> indices;
        std::vector<float> distances;
        for (std::size_t q = 0; q < points.size(); q += 397) {
            const float radius = 0.05f + 0.1f * float(q % 3);
            grid.radius_search(points[q], radius, indices, distances);
            std::vector<std::uint32_t> expected;
            for (std::size_t i = 0; i < points.size(); ++i)
                if (brute_distance(points[i], points[q]) < radius * radius) expected.push_back(std::uint32_t(i));
            ASSERT_EQ(indices.size(), distances.size());
            for (std::size_t j = 0; j < indices.size(); ++j)
                EXPECT_EQ(distances[j], brute_distance(points[indices[j]], points[q]));
            std::sort(indices.begin(), indices.end());
            EXPECT_EQ(indices, expected) << "cell " << cell << " query " << q;
        }
    }
}

// Shared neighbourhoods are the searches themselves, list for list and in order, for the radius
// they were made with and for any smaller one; a larger radius is refused.
TEST(NeighborGrid, NeighborhoodsAreTheRadiusSearchesOfEachCentre)
{
    const auto points = test::random_points(20000, 11);
    const NeighborGrid grid(points, 0.08f);
    std::vector<Point> centers;
    for (std::size_t q = 0; q < points.size(); q += 97) centers.push_back(points[q]);
    centers.push_back(Point(5.0f, 5.0f, 5.0f));  // far from every point: an empty list
    const float radius = 0.08f;
    const Neighborhoods hoods = grid.radius_neighborhoods(centers, radius);
    ASSERT_EQ(hoods.size(), centers.size());
    EXPECT_EQ(hoods.radius, radius);
    EXPECT_TRUE(hoods.is_of(points, centers));
    EXPECT_FALSE(hoods.is_of(std::span(points).first(10), centers));
    EXPECT_FALSE(hoods.is_of(points, std::span(centers).first(3)));
    std::vector<std::uint32_t> expected, got;
    std::vector<float> expected_d2, got_d2;
    for (std::size_t c = 0; c < centers.size(); ++c) {
        grid.radius_search(centers[c], radius, expected, expected_d2);
        EXPECT_TRUE(std::equal(expected.begin(), expected.end(), hoods.indices_of(c).begin(), hoods.indices_of(c).end()))
            << "centre " << c;
        EXPECT_TRUE(std::equal(expected_d2.begin(), expected_d2.end(), hoods.squared_distances_of(c).begin(),
                               hoods.squared_distances_of(c).end()));
        for (const float smaller : {0.08f, 0.05f, 0.0123f}) {
            grid.radius_search(centers[c], smaller, expected, expected_d2);
            hoods.within(c, smaller, got, got_d2);
            EXPECT_EQ(got, expected) << "centre " << c << " radius " << smaller;
            EXPECT_EQ(got_d2, expected_d2);
        }
    }
    EXPECT_TRUE(hoods.indices_of(centers.size() - 1).empty());
    EXPECT_THROW(hoods.within(0, 0.09f, got, got_d2), Error);
    for (const float bad : {0.0f, -0.1f, std::numeric_limits<float>::quiet_NaN()})
        EXPECT_THROW(grid.radius_neighborhoods(centers, bad), Error) << bad;
    const Neighborhoods none = grid.radius_neighborhoods({}, radius);
    EXPECT_EQ(none.size(), 0u);
    EXPECT_TRUE(none.is_of(points, {}));  // no centres (a scene without keypoints) serve no centres
}

// Centres are searched in groups that share their rows: each must still get exactly its own
// radius_search, for radii below, at and beyond the cell size, centres on and off the points (and
// outside the grid), a NaN centre (no neighbours) and centres given twice.
TEST(NeighborGrid, GroupedNeighborhoodsEqualEachCentresSearchAtAnyRadius)
{
    const auto points = test::random_points(20000, 17);
    std::mt19937 rng(8);
    std::uniform_real_distribution<float> coordinate(-1.3f, 1.3f);
    std::vector<Point> centers;
    for (std::size_t q = 0; q < points.size(); q += 37) centers.push_back(points[q]);
    for (int q = 0; q < 300; ++q) centers.emplace_back(coordinate(rng), coordinate(rng), coordinate(rng));
    // Clusters of centres a few millimetres apart, so groups hold many centres whose boxes share
    // their lowest cell but not their highest.
    for (int cluster = 0; cluster < 20; ++cluster) {
        const Point base(coordinate(rng), coordinate(rng), coordinate(rng));
        for (int i = 0; i < 27; ++i)
            centers.push_back(base + 0.004f * Point(float(i % 3), float(i / 3 % 3), float(i / 9)));
    }
    centers.push_back(centers[5]);
    centers.emplace_back(std::numeric_limits<float>::infinity(), 0.0f, 0.0f);
    centers.emplace_back(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f);
    const NeighborGrid grid(points, 0.08f);
    std::vector<std::uint32_t> expected;
    std::vector<float> expected_d2;
    for (const float radius : {0.013f, 0.05f, 0.08f, 0.11f, 0.3f}) {
        const Neighborhoods hoods = grid.radius_neighborhoods(centers, radius);
        ASSERT_EQ(hoods.size(), centers.size());
        for (std::size_t c = 0; c < centers.size(); ++c) {
            grid.radius_search(centers[c], radius, expected, expected_d2);
            const auto got = hoods.indices_of(c);
            const auto got_d2 = hoods.squared_distances_of(c);
            ASSERT_TRUE(std::equal(expected.begin(), expected.end(), got.begin(), got.end()))
                << "radius " << radius << " centre " << c;
            ASSERT_TRUE(std::equal(expected_d2.begin(), expected_d2.end(), got_d2.begin(), got_d2.end()));
        }
        EXPECT_TRUE(hoods.indices_of(centers.size() - 1).empty());
        EXPECT_TRUE(hoods.indices_of(centers.size() - 2).empty());
    }
}

TEST(NeighborGrid, KnnSearchMatchesBruteForceIncludingTies)
{
    // Lattice-snapped points make exact distance ties, which must go to the lower index.
    const auto points = test::random_points(5000, 11);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> coordinate(-1.3f, 1.3f);
    for (float cell : {0.02f, 0.1f, 0.5f}) {
        const NeighborGrid grid(points, cell);
        std::vector<std::uint32_t> indices;
        std::vector<float> distances;
        for (int q = 0; q < 60; ++q) {
            const Point center = q % 2 ? points[std::size_t(q) * 61] : Point(coordinate(rng), coordinate(rng), coordinate(rng));
            const int k = 1 + q % 17;
            grid.knn_search(center, k, indices, distances);
            std::vector<std::pair<float, std::uint32_t>> all;
            for (std::size_t i = 0; i < points.size(); ++i) all.emplace_back(brute_distance(points[i], center), std::uint32_t(i));
            std::partial_sort(all.begin(), all.begin() + k, all.end());
            ASSERT_EQ(indices.size(), std::size_t(k));
            for (int j = 0; j < k; ++j) {
                EXPECT_EQ(indices[std::size_t(j)], all[std::size_t(j)].second) << "cell " << cell << " q " << q;
                EXPECT_EQ(distances[std::size_t(j)], all[std::size_t(j)].first);
            }
        }
    }
}

TEST(NeighborGrid, NearestWithinRadiusMatchesBruteForce)
{
    const auto points = test::random_points(5000, 13);
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> coordinate(-1.5f, 1.5f);
    for (float cell : {0.02f, 0.1f}) {
        const NeighborGrid grid(points, cell);
        for (int q = 0; q < 300; ++q) {
            const Point center(coordinate(rng), coordinate(rng), coordinate(rng));
            const float radius = 0.01f + 0.05f * float(q % 5);
            expect_nearest_as_brute_force(grid, points, center, radius, q);
        }
    }
}

TEST(NeighborGrid, AnExtentOfMillionsOfCellsPerAxisStillFindsEveryNeighbour)
{
    // Almost 2^21 cells per axis: the cell numbers take 63 bits.
    std::mt19937 rng(6);
    std::uniform_real_distribution<float> coordinate(-1000.0f, 1000.0f);
    std::vector<Point> points;
    for (int i = 0; i < 300; ++i) points.emplace_back(coordinate(rng), coordinate(rng), coordinate(rng));
    for (int i = 0; i < 300; ++i) points.push_back(points[std::size_t(i)] + Point(0.0004f, -0.0003f, 0.0002f));
    const NeighborGrid grid(points, 0.001f);
    std::vector<std::uint32_t> indices;
    std::vector<float> distances;
    for (std::uint32_t q = 0; q < points.size(); q += 7) {
        grid.knn_search(points[q], 2, indices, distances);
        ASSERT_EQ(indices.size(), 2u);
        const std::uint32_t twin = q < 300 ? q + 300 : q - 300;
        EXPECT_EQ(indices[0], q);
        EXPECT_EQ(indices[1], twin);
        grid.radius_search(points[q], 0.01f, indices, distances);
        std::sort(indices.begin(), indices.end());
        EXPECT_EQ(indices, (std::vector<std::uint32_t>{std::min(q, twin), std::max(q, twin)}));
    }
}

// Cells whose keys share a whole sort digit (one row of cells, x cells all multiples of 2048, so
// the low 11-bit digit of every key is 0): the pass over that digit is skipped, and every query
// still finds what a scan finds.
TEST(NeighborGrid, KeysSharingADigitAreStillSorted)
{
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> jitter(0.1f, 0.9f);
    std::vector<Point> points;
    for (int i = 0; i < 400; ++i) {
        const float cell_x = float(2048 * (i % 13));
        points.emplace_back(cell_x + jitter(rng), jitter(rng), jitter(rng));
    }
    const NeighborGrid grid(points, 1.0f);
    std::vector<std::uint32_t> indices;
    std::vector<float> distances;
    for (std::size_t q = 0; q < points.size(); q += 3) {
        grid.radius_search(points[q], 1.5f, indices, distances);
        std::vector<std::uint32_t> expected;
        for (std::size_t i = 0; i < points.size(); ++i)
            if (brute_distance(points[i], points[q]) < 1.5f * 1.5f) expected.push_back(std::uint32_t(i));
        std::sort(indices.begin(), indices.end());
        EXPECT_EQ(indices, expected) << "query " << q;
        expect_nearest_as_brute_force(grid, points, points[q] + Point(0.3f, -0.2f, 0.1f), 2.0f, int(q));
    }
}

TEST(NeighborGrid, NearestBreaksTiesByIndexOnCellFaces)
{
    // Points on a lattice of the cell size, so every one lies on cell faces, shuffled and some
    // duplicated; queries half a step off the lattice are equidistant from 2, 4 or 8 of them.
    const float step = 0.125f;  // exact in binary, so the ties are exact
    std::vector<Point> points;
    for (int x = 0; x < 8; ++x)
        for (int y = 0; y < 8; ++y)
            for (int z = 0; z < 8; ++z) points.emplace_back(step * float(x), step * float(y), step * float(z));
    std::mt19937 rng(8);
    std::shuffle(points.begin(), points.end(), rng);
    for (std::size_t i = 0; i < 50; ++i) points.push_back(points[i * 7]);
    std::uniform_int_distribution<int> half_steps(-2, 16);
    for (float cell : {step, 2.0f * step}) {
        const NeighborGrid grid(points, cell);
        for (int q = 0; q < 400; ++q) {
            const Point center(0.5f * step * float(half_steps(rng)), 0.5f * step * float(half_steps(rng)),
                               0.5f * step * float(half_steps(rng)));
            const float radius = step * float(1 + q % 3);
            expect_nearest_as_brute_force(grid, points, center, radius, q);
        }
    }
}

// Two points 819 m either side of the centre, at exactly equal distances: the lower index wins.
// The far point's cell and its cell's edge both round at the magnitude of its coordinates (its edge
// lies above the point itself), so a row skipped for lying farther than the best so far must allow
// for that rounding, as the search box does.
TEST(NeighborGrid, NearestKeepsTheTieInARowThatRoundsAway)
{
    const float far = 13425049.0f / 16384.0f;
    const std::vector<Point> points = {Point(0.0f, far, 0.0f), Point(0.0f, -far, 0.0f)};
    const NeighborGrid grid(points, 0.1f);
    expect_nearest_as_brute_force(grid, points, Point(0.0f, 0.0f, 0.0f), 1000.0f, 0);
}

// Outliers metres from a millimetre-cell patch: their k nearest lie thousands of shells away, which
// shell by shell would take ~1e12 row lookups (a hang); the search reads every point instead, and
// finds what a scan finds, alone and in a batch.
TEST(NeighborGrid, KnnOfOutliersFarFromEverythingMatchesBruteForce)
{
    std::vector<Point> points;
    for (int i = 0; i < 60; ++i)
        for (int j = 0; j < 60; ++j) points.emplace_back(0.001f * float(i), 0.001f * float(j), 1.0f);
    for (int o = 1; o <= 5; ++o) points.emplace_back(2.0f * float(o), 0.03f * float(o), 1.0f - 0.5f * float(o));
    const NeighborGrid grid(points, 0.001f);
    std::vector<std::uint32_t> indices;
    std::vector<float> distances;
    std::vector<Point> queries;
    for (std::size_t q = points.size() - 5; q < points.size(); ++q) queries.push_back(points[q]);
    queries.emplace_back(-7.0f, 0.02f, 3.0f);  // beside no point at all
    for (const int k : {1, 4, 12}) {
        std::vector<std::uint32_t> batch_indices(queries.size() * std::size_t(k));
        std::vector<float> batch_distances(batch_indices.size());
        grid.knn_search_batch(queries, k, batch_indices, batch_distances);
        for (std::size_t q = 0; q < queries.size(); ++q) {
            grid.knn_search(queries[q], k, indices, distances);
            std::vector<std::pair<float, std::uint32_t>> all;
            for (std::size_t i = 0; i < points.size(); ++i)
                all.emplace_back(brute_distance(points[i], queries[q]), std::uint32_t(i));
            std::partial_sort(all.begin(), all.begin() + k, all.end());
            ASSERT_EQ(indices.size(), std::size_t(k));
            for (std::size_t j = 0; j < std::size_t(k); ++j) {
                EXPECT_EQ(indices[j], all[j].second) << "k " << k << " query " << q;
                EXPECT_EQ(distances[j], all[j].first);
                EXPECT_EQ(batch_indices[q * std::size_t(k) + j], all[j].second);
            }
        }
    }
}

TEST(NeighborGrid, FewerPointsThanKAndFarQueries)
{
    const std::vector<Point> points = {Point(0, 0, 0), Point(1, 0, 0), Point(0, 2, 0)};
    const NeighborGrid grid(points, 0.1f);
    std::vector<std::uint32_t> indices;
    std::vector<float> distances;
    grid.knn_search(Point(0.1f, 0, 0), 10, indices, distances);
    EXPECT_EQ(indices, (std::vector<std::uint32_t>{0, 1, 2}));
    grid.knn_search(Point(500, 500, 500), 1, indices, distances);
    EXPECT_EQ(indices, (std::vector<std::uint32_t>{2}));
    grid.radius_search(Point(500, 500, 500), 1.0f, indices, distances);
    EXPECT_TRUE(indices.empty());
    grid.radius_search(Point(-1e30f, 0, 0), 1.0f, indices, distances);
    EXPECT_TRUE(indices.empty());
}

TEST(NeighborGrid, EmptyCloudAndBadCellSize)
{
    const std::vector<Point> none;
    const NeighborGrid grid(none, 0.1f);
    std::vector<std::uint32_t> indices;
    std::vector<float> distances;
    grid.knn_search(Point::Zero(), 3, indices, distances);
    EXPECT_TRUE(indices.empty());
    grid.radius_search(Point::Zero(), 3, indices, distances);
    EXPECT_TRUE(indices.empty());
    EXPECT_THROW(NeighborGrid(none, 0.0f), Error);
    EXPECT_THROW(NeighborGrid(none, -1.0f), Error);
    // Cells are numbered within 1e9 of the origin: 1e8 cells out is a grid, 1e10 is not.
    const std::vector<Point> spread = {Point(0, 0, 0), Point(1e5f, 0, 0)};
    EXPECT_EQ(NeighborGrid(spread, 0.001f).size(), 2u);
    const std::vector<Point> too_far = {Point(0, 0, 0), Point(1e7f, 0, 0)};
    EXPECT_THROW(NeighborGrid(too_far, 0.001f), Error);
}

// A stray point kilometres out on one axis leaves the cells' row-major numbers within 64 bits;
// strays out on three axes do not, and the grid sorts its cells by row and x instead. Either way
// every query finds what a scan of every point finds.
TEST(NeighborGrid, StrayPointsKilometresOutLeaveEveryQueryExact)
{
    const auto scene = test::random_points(3000, 21);
    const std::vector<std::vector<Point>> stray_sets = {
        {Point(5e5f, 0.5f, 0.25f)},
        {Point(3e6f, -2e6f, 4e6f), Point(-4e6f, 1e6f, -3e6f), Point(3e6f, -2e6f + 0.125f, 4e6f)}};
    const NeighborGrid scene_grid(scene, 0.1f);
    for (const auto& strays : stray_sets) {
        std::vector<Point> points = scene;
        points.insert(points.end(), strays.begin(), strays.end());
        const NeighborGrid grid(points, 0.1f);
        std::vector<Point> queries;
        for (std::size_t q = 0; q < scene.size(); q += 50) queries.push_back(scene[q]);
        for (const Point& stray : strays) queries.push_back(stray), queries.push_back(stray + Point(0.2f, 0, 0));
        queries.emplace_back(1.5f, -1.2f, 0.7f);
        const float radius = 0.25f;
        const Neighborhoods hoods = grid.radius_neighborhoods(queries, radius);
        constexpr int k = 6;
        std::vector<std::uint32_t> batch_indices(queries.size() * k);
        std::vector<float> batch_distances(batch_indices.size());
        grid.knn_search_batch(queries, k, batch_indices, batch_distances);
        std::vector<std::uint32_t> indices;
        std::vector<float> distances;
        for (std::size_t q = 0; q < queries.size(); ++q) {
            std::vector<std::pair<float, std::uint32_t>> all;
            std::vector<std::uint32_t> within;
            for (std::uint32_t i = 0; i < points.size(); ++i) {
                all.emplace_back(brute_distance(points[i], queries[q]), i);
                if (all.back().first < radius * radius) within.push_back(i);
            }
            grid.radius_search(queries[q], radius, indices, distances);
            const auto hood = hoods.indices_of(q);
            EXPECT_TRUE(std::equal(indices.begin(), indices.end(), hood.begin(), hood.end()))
                << "strays " << strays.size() << " query " << q;
            // Cells are anchored at the origin, so around the scene the strays change nothing,
            // not even the order (cell by cell) in which the points come.
            if (q < scene.size() / 50) {
                std::vector<std::uint32_t> scene_indices;
                std::vector<float> scene_distances;
                scene_grid.radius_search(queries[q], radius, scene_indices, scene_distances);
                EXPECT_EQ(indices, scene_indices) << "strays " << strays.size() << " query " << q;
            }
            std::sort(indices.begin(), indices.end());
            EXPECT_EQ(indices, within) << "strays " << strays.size() << " query " << q;
            std::partial_sort(all.begin(), all.begin() + k, all.end());
            grid.knn_search(queries[q], k, indices, distances);
            for (std::size_t j = 0; j < std::size_t(k); ++j) {
                EXPECT_EQ(indices[j], all[j].second) << "strays " << strays.size() << " query " << q;
                EXPECT_EQ(batch_indices[q * k + j], all[j].second) << "strays " << strays.size() << " query " << q;
            }
            expect_nearest_as_brute_force(grid, points, queries[q], radius, int(q));
        }
    }
}

}  // namespace
}  // namespace mfpc
