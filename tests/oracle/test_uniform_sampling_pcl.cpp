#include <algorithm>
#include <iostream>
#include <limits>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <pcl/filters/uniform_sampling.h>

#include "mfpc/core/error.hpp"
#include "mfpc/kernels/uniform_sampling.hpp"
#include "oracle_support.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using Triple = std::tuple<float, float, float>;

// PCL's UniformSampling returns points, not indices: compare the selected coordinates as sets.
void expect_same_selection(const std::filesystem::path& path, float radius)
{
    // The cloud and its PCL twin only: sampling needs no normals.
    const auto oracle = test::load_oracle_cloud(path, 1000000, false);
    const auto kept = uniform_sampling(oracle.cloud.points, radius);
    std::vector<Triple> ours;
    for (auto i : kept) ours.emplace_back(oracle.cloud.points[i].x(), oracle.cloud.points[i].y(), oracle.cloud.points[i].z());

    pcl::UniformSampling<pcl::PointXYZ> sampling;
    sampling.setInputCloud(oracle.pcl_cloud);
    sampling.setRadiusSearch(radius);
    pcl::PointCloud<pcl::PointXYZ> selected;
    sampling.filter(selected);
    std::vector<Triple> theirs;
    for (const auto& p : selected) theirs.emplace_back(p.x, p.y, p.z);

    std::sort(ours.begin(), ours.end());
    std::sort(theirs.begin(), theirs.end());
    std::cout << path.filename().string() << " radius " << radius << ": " << ours.size() << " keypoints (PCL "
              << theirs.size() << ")\n";
    EXPECT_EQ(ours, theirs);
}

TEST(UniformSamplingOracle, SceneSelectionIsPcls)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_cartoon_all_small_clorox.pcd");
    for (float radius : {0.03f, 0.01f, 0.0037f}) expect_same_selection(path, radius);
}

TEST(UniformSamplingOracle, ModelSelectionIsPcls)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk.pcd");
    for (float radius : {0.01f, 0.005f, 0.0021f}) expect_same_selection(path, radius);
}

// Cube numbers beyond int were an undefined conversion (PCL's too), which once sized a table from
// garbage: a point that far out, or not finite, is named instead.
TEST(UniformSampling, FarOrNonFinitePointsAreNamed)
{
    for (const float far : {1e20f, std::numeric_limits<float>::quiet_NaN(), -1e12f}) {
        std::vector<Point> points = {{0.0f, 0.0f, 0.0f}, {0.01f, 0.0f, 0.0f}, {0.0f, far, 0.0f}, {far, 0.0f, 1.0f}};
        try {
            uniform_sampling(points, 0.01f);
            ADD_FAILURE() << far << " was taken";
        } catch (const Error& error) {
            EXPECT_EQ(std::string(error.what()),
                      "uniform_sampling: point 2 is not finite or lies more than 2^30 cubes of 0.01 m from the origin");
        }
    }
}

// A stray point 100 km out puts the cloud past 2^21 cubes per axis, the cube table's key: the
// occupied cubes are then numbered by rank, and the kept points are those of each part on its own.
TEST(UniformSampling, AStrayPointFarOutKeepsTheSameSelection)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk.pcd");
    const auto oracle = test::load_oracle_cloud(path, 1000000, false);
    std::vector<Point> points = oracle.cloud.points;
    const std::vector<std::uint32_t> alone = uniform_sampling(points, 0.01f);
    points.emplace_back(1e5f, -3e4f, 7e4f);
    const std::vector<std::uint32_t> with_stray = uniform_sampling(points, 0.01f);
    std::vector<std::uint32_t> expected = alone;
    expected.push_back(std::uint32_t(points.size() - 1));
    EXPECT_EQ(with_stray, expected);
}

}  // namespace
}  // namespace mfpc
