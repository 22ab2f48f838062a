#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/pcl_adapter.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

constexpr float nan = std::numeric_limits<float>::quiet_NaN();

bool same_bits(const Point& a, const Point& b)
{
    return std::memcmp(a.data(), b.data(), 3 * sizeof(float)) == 0;
}

TEST(PclAdapter, OrganizedCloudKeepsFinitePointsAndTheirPixels)
{
    pcl::PointCloud<pcl::PointXYZ> in(4, 3);
    for (std::size_t i = 0; i < in.size(); ++i) in[i] = pcl::PointXYZ(float(i), float(i) * 2, -float(i));
    in[1].x = nan;
    in[6].z = std::numeric_limits<float>::infinity();
    in[11].y = nan;
    in.is_dense = false;

    const PointCloud cloud = from_pcl(in);
    EXPECT_EQ(cloud.width, 4u);
    EXPECT_EQ(cloud.height, 3u);
    ASSERT_EQ(cloud.size(), 9u);
    EXPECT_EQ(cloud.source_index, (std::vector<std::uint32_t>{0, 2, 3, 4, 5, 7, 8, 9, 10}));
    EXPECT_EQ(cloud.points[3], Point(4, 8, -4));  // source 4
    EXPECT_FALSE(cloud.has_colors());
    EXPECT_NO_THROW(check_cloud(cloud, "from_pcl"));
}

TEST(PclAdapter, DenseCloudGetsTheIdentityIndexMap)
{
    pcl::PointCloud<pcl::PointXYZ> in;
    for (int i = 0; i < 5; ++i) in.push_back(pcl::PointXYZ(float(i), 1, 2));
    const PointCloud cloud = from_pcl(in);
    EXPECT_EQ(cloud.size(), 5u);
    EXPECT_TRUE(cloud.source_index.empty());
    EXPECT_EQ(cloud.width, 5u);
    EXPECT_EQ(cloud.height, 1u);
}

TEST(PclAdapter, CloudWhoseGridDisagreesWithItsSizeIsTreatedAsAList)
{
    pcl::PointCloud<pcl::PointXYZ> in(2, 2);
    in.push_back(pcl::PointXYZ(9, 9, 9));  // now 5 points in a "2 x 2" cloud
    in.width = 2;
    in.height = 2;
    in[0].x = nan;
    const PointCloud cloud = from_pcl(in);
    EXPECT_EQ(cloud.width, 5u);
    EXPECT_EQ(cloud.height, 1u);
    EXPECT_EQ(cloud.source_index, (std::vector<std::uint32_t>{1, 2, 3, 4}));
    EXPECT_NO_THROW(check_cloud(cloud, "from_pcl"));
}

TEST(PclAdapter, ColoursComeAlongAndAlphaIsDropped)
{
    pcl::PointCloud<pcl::PointXYZRGBA> in;
    pcl::PointXYZRGBA a;
    a.x = 1, a.y = 2, a.z = 3, a.r = 10, a.g = 20, a.b = 30, a.a = 40;
    pcl::PointXYZRGBA hole = a;
    hole.y = nan;
    in.push_back(hole);
    in.push_back(a);
    const PointCloud cloud = from_pcl(in);
    ASSERT_EQ(cloud.size(), 1u);
    EXPECT_EQ(cloud.colors, (std::vector<Rgb>{{10, 20, 30}}));
    EXPECT_EQ(cloud.source_index, (std::vector<std::uint32_t>{1}));
}

TEST(PclAdapter, ToPclIsAnUnorganizedCopy)
{
    PointCloud cloud;
    cloud.points = {Point(1, 2, 3), Point(-0.0f, 1e-40f, 7)};
    cloud.source_index = {5, 9};
    cloud.width = 5;
    cloud.height = 2;
    const pcl::PointCloud<pcl::PointXYZ> out = to_pcl(cloud);
    ASSERT_EQ(out.size(), 2u);
    EXPECT_EQ(out.width, 2u);
    EXPECT_EQ(out.height, 1u);
    EXPECT_TRUE(out.is_dense);
    for (std::size_t i = 0; i < 2; ++i) EXPECT_TRUE(same_bits(cloud.points[i], Point(out[i].x, out[i].y, out[i].z)));
    // And back: a dense list comes back as the same points with the identity map.
    const PointCloud back = from_pcl(out);
    ASSERT_EQ(back.size(), 2u);
    EXPECT_TRUE(back.source_index.empty());
    EXPECT_TRUE(same_bits(back.points[1], cloud.points[1]));
}

TEST(PclAdapter, SceneFromPclEqualsOurRead)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_cartoon_all_small_clorox.pcd");
    pcl::PointCloud<pcl::PointXYZRGBA> theirs;
    ASSERT_EQ(pcl::io::loadPCDFile(path.string(), theirs), 0);
    const PointCloud converted = from_pcl(theirs);
    const PointCloud read = read_cloud(path);
    ASSERT_EQ(converted.size(), read.size());
    EXPECT_EQ(converted.width, read.width);
    EXPECT_EQ(converted.height, read.height);
    EXPECT_EQ(converted.source_index, read.source_index);
    EXPECT_EQ(converted.colors, read.colors);
    std::size_t mismatches = 0;
    for (std::size_t i = 0; i < read.size(); ++i) mismatches += !same_bits(converted.points[i], read.points[i]);
    EXPECT_EQ(mismatches, 0u);
}

}  // namespace
}  // namespace mfpc
