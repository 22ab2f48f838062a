#include <algorithm>
#include <numeric>
#include <random>

#include <gtest/gtest.h>

#include "mfpc/core/error.hpp"
#include "mfpc/index/nearest_neighbors.hpp"
#include "mfpc/index/point_index.hpp"
#include "random_clouds.hpp"

namespace mfpc {
namespace {

TEST(PointIndex, EveryPointOnceInTightLeaves)
{
    const auto points = test::random_points(20000, 7);
    const PointIndex index(points, {0.05f});
    std::vector<std::uint32_t> order(index.point_order().begin(), index.point_order().end());
    std::sort(order.begin(), order.end());
    std::vector<std::uint32_t> expected(points.size());
    std::iota(expected.begin(), expected.end(), 0u);
    EXPECT_EQ(order, expected);

    std::size_t covered = 0;
    std::uint32_t next_voxel = 0;
    for (const PointIndexLeaf& leaf : index.leaves()) {
        ASSERT_GT(leaf.size(), 0u);
        covered += leaf.size();
        // The leaf's voxels partition its points, each voxel ascending, with tight bounds.
        ASSERT_EQ(leaf.voxel_begin, next_voxel);
        next_voxel = leaf.voxel_end;
        std::uint32_t cursor = leaf.begin;
        Box leaf_tight = bounding_box(std::span<const Point>());
        for (std::uint32_t v = leaf.voxel_begin; v < leaf.voxel_end; ++v) {
            const PointIndexVoxel& voxel = index.voxels()[v];
            ASSERT_EQ(voxel.begin, cursor);
            cursor = voxel.end;
            Box tight = bounding_box(std::span<const Point>());
            for (std::uint32_t k = voxel.begin; k < voxel.end; ++k) {
                const Point& p = points[index.point_order()[k]];
                tight.min = tight.min.cwiseMin(p);
                tight.max = tight.max.cwiseMax(p);
                if (k > voxel.begin) {
                    EXPECT_LT(index.point_order()[k - 1], index.point_order()[k]);
                }
            }
            EXPECT_EQ(tight.min, voxel.bounds.min);
            EXPECT_EQ(tight.max, voxel.bounds.max);
            EXPECT_LE(voxel.bounds.size().maxCoeff(), 0.05f + 1e-5f);
            leaf_tight.min = leaf_tight.min.cwiseMin(tight.min);
            leaf_tight.max = leaf_tight.max.cwiseMax(tight.max);
        }
        EXPECT_EQ(cursor, leaf.end);
        EXPECT_EQ(leaf_tight.min, leaf.bounds.min);
        EXPECT_EQ(leaf_tight.max, leaf.bounds.max);
        // A leaf is 8 voxels a side.
        EXPECT_LE(leaf.bounds.size().maxCoeff(), 8 * 0.05f + 1e-5f);
    }
    EXPECT_EQ(next_voxel, index.voxels().size());
    EXPECT_EQ(covered, points.size());
}

TEST(PointIndex, BoxAndRadiusQueriesMatchBruteForce)
{
    const auto points = test::random_points(5000, 11);
    const PointIndex index(points, {0.03f});
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> coordinate(-1.1f, 1.1f);
    std::vector<std::uint32_t> found;
    for (int trial = 0; trial < 50; ++trial) {
        Eigen::Vector3f a(coordinate(rng), coordinate(rng), coordinate(rng));
        Eigen::Vector3f b(coordinate(rng), coordinate(rng), coordinate(rng));
        // Faces on lattice coordinates, where snapped points lie exactly on them.
        if (trial % 2 == 0) {
            a = (a / 0.05f).array().round().matrix() * 0.05f;
            b = (b / 0.05f).array().round().matrix() * 0.05f;
        }
        const Box box{a.cwiseMin(b), a.cwiseMax(b)};
        index.points_in_box(box, found);
        std::vector<std::uint32_t> expected;
        for (std::uint32_t i = 0; i < points.size(); ++i) {
            if (box.contains(points[i])) expected.push_back(i);
        }
        EXPECT_EQ(found, expected) << "box trial " << trial;

        const float radius = 0.3f * std::abs(coordinate(rng));
        index.points_in_radius(a, radius, found);
        expected.clear();
        for (std::uint32_t i = 0; i < points.size(); ++i) {
            if ((points[i] - a).squaredNorm() <= radius * radius) expected.push_back(i);
        }
        EXPECT_EQ(found, expected) << "radius trial " << trial;
    }
}

TEST(PointIndex, RejectsBadVoxelSize)
{
    const auto points = test::random_points(10, 1);
    EXPECT_THROW(PointIndex(points, {0.0f}), Error);
    EXPECT_THROW(PointIndex(points, {-1.0f}), Error);
    EXPECT_THROW(PointIndex(points, {std::numeric_limits<float>::quiet_NaN()}), Error);
}

TEST(PointIndex, EmptyCloud)
{
    const std::vector<Point> points;
    const PointIndex index(points);
    EXPECT_TRUE(index.leaves().empty());
    std::vector<std::uint32_t> found{1, 2};
    index.points_in_box(Box{Eigen::Vector3f::Constant(-1), Eigen::Vector3f::Constant(1)}, found);
    EXPECT_TRUE(found.empty());
}

TEST(MeanSpacing, MatchesBruteForce)
{
    const auto points = test::random_points(2000, 5);
    double expected = 0.0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        float nearest = std::numeric_limits<float>::infinity();
        for (std::size_t j = 0; j < points.size(); ++j) {
            if (i != j) nearest = std::min(nearest, (points[i] - points[j]).squaredNorm());
        }
        expected += std::sqrt(double(nearest));
    }
    expected /= double(points.size());
    EXPECT_NEAR(mean_spacing(points), expected, 1e-6 * expected);
    EXPECT_EQ(mean_spacing(std::span<const Point>(points).first(1)), 0.0);
}

TEST(MeanSpacing, RegularGrid)
{
    std::vector<Point> grid;
    for (int i = 0; i < 30; ++i) {
        for (int j = 0; j < 30; ++j) grid.emplace_back(0.002f * float(i), 0.002f * float(j), 1.0f);
    }
    EXPECT_NEAR(mean_spacing(grid), 0.002, 1e-6);
}

}  // namespace
}  // namespace mfpc
