// voxel_grid against the obvious version: a map from cube to its points, in index order.
#include <cmath>
#include <cstring>
#include <map>
#include <tuple>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "mfpc/core/error.hpp"
#include "mfpc/kernels/voxel_grid.hpp"
#include "random_clouds.hpp"

namespace mfpc {
namespace {

VoxelGrid reference_voxel_grid(const std::vector<Point>& points, float voxel)
{
    std::map<std::tuple<long, long, long>, std::vector<std::uint32_t>> cubes;
    for (std::uint32_t i = 0; i < points.size(); ++i) {
        const Point& p = points[i];
        const double inverse = 1.0 / double(voxel);
        cubes[{long(std::floor(double(p.x()) * inverse)), long(std::floor(double(p.y()) * inverse)),
               long(std::floor(double(p.z()) * inverse))}]
            .push_back(i);
    }
    std::map<std::uint32_t, Point> by_first;
    for (const auto& [cube, members] : cubes) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (std::uint32_t i : members) sum += points[i].cast<double>();
        by_first[members.front()] = (sum / double(members.size())).cast<float>();
    }
    VoxelGrid out;
    for (const auto& [first, centroid] : by_first) {
        out.first.push_back(first);
        out.centroids.push_back(centroid);
    }
    return out;
}

TEST(VoxelGrid, EqualsTheReferenceOnRandomClouds)
{
    for (std::uint32_t seed = 1; seed <= 4; ++seed) {
        const std::vector<Point> points = test::random_points(20000, seed);
        for (const float voxel : {0.005f, 0.05f, 0.3f}) {
            const VoxelGrid fast = voxel_grid(points, voxel);
            const VoxelGrid slow = reference_voxel_grid(points, voxel);
            ASSERT_EQ(fast.first, slow.first) << "seed " << seed << " voxel " << voxel;
            ASSERT_EQ(fast.centroids.size(), slow.centroids.size());
            for (std::size_t v = 0; v < fast.centroids.size(); ++v)
                ASSERT_EQ(fast.centroids[v], slow.centroids[v]) << "voxel " << v;
        }
    }
}

TEST(VoxelGrid, OnePointPerVoxelWhateverTheSampling)
{
    // A plane sampled at 1 mm and at 2.5 mm gives the same voxels at 5 mm: the point of resampling.
    auto plane = [](float step) {
        std::vector<Point> points;
        for (float x = 0.0005f; x < 0.2f; x += step)
            for (float y = 0.0005f; y < 0.2f; y += step) points.emplace_back(x, y, 1.0f);
        return points;
    };
    const VoxelGrid dense = voxel_grid(plane(0.001f), 0.005f);
    const VoxelGrid sparse = voxel_grid(plane(0.0025f), 0.005f);
    EXPECT_EQ(dense.centroids.size(), 40u * 40u);
    EXPECT_EQ(sparse.centroids.size(), dense.centroids.size());
}

TEST(VoxelGrid, SameBytesAtAnyThreadCount)
{
    const std::vector<Point> points = test::random_points(50000, 9);
    VoxelGrid one, two;
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        one = voxel_grid(points, 0.02f);
    }
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
        two = voxel_grid(points, 0.02f);
    }
    ASSERT_EQ(one.first, two.first);
    ASSERT_EQ(one.centroids.size(), two.centroids.size());
    EXPECT_EQ(0, std::memcmp(one.centroids.data(), two.centroids.data(), one.centroids.size() * sizeof(Point)));
}

TEST(VoxelGrid, WideCloudsAndBadInput)
{
    // Points 2^22 voxels apart do not fit the packed keys: the cells are ranked instead.
    std::vector<Point> wide = {Point(0, 0, 0), Point(20000.0f, 0, 0), Point(0.001f, 0, 0), Point(20000.002f, 0, 0)};
    const VoxelGrid grid = voxel_grid(wide, 0.005f);
    EXPECT_EQ(grid.first, (std::vector<std::uint32_t>{0, 1}));
    EXPECT_TRUE(voxel_grid({}, 0.01f).centroids.empty());
    EXPECT_THROW(voxel_grid(wide, 0.0f), Error);
    EXPECT_THROW(voxel_grid(wide, std::nanf("")), Error);
    EXPECT_THROW(voxel_grid(std::vector<Point>{Point(1e30f, 0, 0)}, 0.005f), Error);
    EXPECT_THROW(voxel_grid(std::vector<Point>{Point(0, std::nanf(""), 0)}, 0.005f), Error);
}

}  // namespace
}  // namespace mfpc
