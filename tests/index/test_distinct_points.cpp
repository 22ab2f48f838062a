// Exact duplicates: found in one pass whatever their number, the same at any thread count, and
// collapsed before the searches that would be quadratic in them.
#include <map>
#include <random>
#include <tuple>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "mfpc/core/error.hpp"
#include "mfpc/index/distinct_points.hpp"
#include "mfpc/index/nearest_neighbors.hpp"
#include "random_clouds.hpp"

namespace mfpc {
namespace {

// The plain way: the first index seen at each position (+0 and -0 as one).
std::vector<std::uint32_t> reference_first(const std::vector<Point>& points)
{
    std::map<std::tuple<float, float, float>, std::uint32_t> seen;
    std::vector<std::uint32_t> first(points.size());
    for (std::uint32_t i = 0; i < points.size(); ++i) {
        const Point& p = points[i];
        const auto key = std::tuple(p.x() + 0.0f, p.y() + 0.0f, p.z() + 0.0f);  // -0 + 0 is +0
        first[i] = seen.emplace(key, i).first->second;
    }
    return first;
}

// Random points, then copies of some of them (a tenth, up to five copies each) shuffled in, a
// -0 twin of a +0 coordinate among them.
std::vector<Point> cloud_with_copies(std::size_t n, unsigned seed)
{
    std::vector<Point> points = test::random_points(n, seed);
    points[0] = Point(0.0f, 0.25f, 1.0f);
    points.emplace_back(-0.0f, 0.25f, 1.0f);
    std::mt19937 random(seed);
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);
    for (std::size_t i = 0; i < n / 10; ++i) {
        const Point copy = points[pick(random)];
        for (int c = 0; c < 1 + int(random() % 5); ++c) points.push_back(copy);
    }
    std::shuffle(points.begin(), points.end(), random);
    return points;
}

TEST(DistinctPoints, MatchesThePlainWayAtAnyThreadCount)
{
    for (unsigned seed : {1u, 2u, 3u}) {
        const std::vector<Point> points = cloud_with_copies(3000 + 1000 * seed, seed);
        const std::vector<std::uint32_t> expected = reference_first(points);
        for (int threads : {1, 2, 4}) {
            const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
            const DistinctPoints distinct = distinct_points(points);
            ASSERT_FALSE(distinct.all_distinct());
            EXPECT_EQ(distinct.first, expected) << "seed " << seed << ", " << threads << " threads";
            std::size_t heads = 0;
            for (std::uint32_t i = 0; i < expected.size(); ++i) heads += expected[i] == i;
            EXPECT_EQ(distinct.count, heads);
            const std::vector<std::uint32_t> representatives = distinct.representatives(points.size());
            EXPECT_EQ(representatives.size(), heads);
            EXPECT_TRUE(std::is_sorted(representatives.begin(), representatives.end()));
        }
    }
}

TEST(DistinctPoints, DistinctCloudsAllocateNothing)
{
    // (random_points snaps some to a lattice, where they meet.)
    std::vector<Point> points;
    for (int i = 0; i < 5000; ++i) points.emplace_back(0.001f * float(i % 71), 0.001f * float(i / 71), 1.0f);
    const DistinctPoints distinct = distinct_points(points);
    EXPECT_TRUE(distinct.all_distinct());
    EXPECT_EQ(distinct.count, points.size());
    EXPECT_EQ(distinct.representatives(points.size()).size(), points.size());
    EXPECT_TRUE(distinct_points(std::vector<Point>{}).all_distinct());
}

// 2^20 copies of one point: a pairwise comparison anywhere would not finish within the test's
// timeout, and mean_spacing searched them all before.
TEST(DistinctPoints, MillionsOfCopiesOfOnePointAreOnePosition)
{
    std::vector<Point> points(std::size_t(1) << 20, Point(0.1f, -0.2f, 1.5f));
    points.emplace_back(0.1f, -0.2f, 1.502f);
    const DistinctPoints distinct = distinct_points(points);
    EXPECT_EQ(distinct.count, 2u);
    EXPECT_EQ(distinct.first[points.size() - 2], 0u);
    EXPECT_EQ(distinct.first.back(), points.size() - 1);
    // Every point but the last has a copy at distance 0; the last is 2 mm from the rest.
    EXPECT_NEAR(mean_spacing(points), 0.002 / double(points.size()), 1e-12);
}

TEST(MeanSpacing, CopiesCountAsDistanceZero)
{
    std::vector<Point> points = test::random_points(1500, 4);
    const std::size_t distinct = points.size();
    for (std::size_t i = 0; i < 200; ++i) points.push_back(points[i * 3]);
    double expected = 0.0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        float nearest = std::numeric_limits<float>::infinity();
        for (std::size_t j = 0; j < points.size(); ++j)
            if (i != j) nearest = std::min(nearest, (points[i] - points[j]).squaredNorm());
        expected += std::sqrt(double(nearest));
    }
    expected /= double(points.size());
    EXPECT_NEAR(mean_spacing(points), expected, 1e-6 * expected);
    EXPECT_LT(mean_spacing(points), mean_spacing(std::span<const Point>(points).first(distinct)));
    EXPECT_EQ(mean_spacing(std::vector<Point>(1000, Point(1, 2, 3))), 0.0);
}

// FLANN's tree build recursed without end on coordinates whose differences overflow.
TEST(MeanSpacing, RefusesCoordinatesBeyondTheRange)
{
    std::vector<Point> points = test::random_points(100, 6);
    points[42] = Point(1.7e38f, -1.7e38f, 0.0f);
    try {
        mean_spacing(points);
        ADD_FAILURE() << "no error";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("point 42"), std::string::npos) << error.what();
    }
    points[42] = Point(max_coordinate, -max_coordinate, max_coordinate);
    EXPECT_GT(mean_spacing(points), 0.0);
}

}  // namespace
}  // namespace mfpc
