#include <algorithm>
#include <numeric>
#include <random>

#include <gtest/gtest.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/PointIndexGrid.h>
#include <tbb/global_control.h>

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

// OpenVDB's own builder as the oracle: tools::createPointIndexGrid with the index's transform
// (voxel (i, j, k) covers [i, i + 1) * voxel) must give the same leaves, voxels and point lists.
struct PointArray {
    using PosType = openvdb::Vec3R;
    const std::vector<Point>* points;
    std::size_t size() const { return points->size(); }
    void getPos(std::size_t n, PosType& xyz) const { xyz = PosType((*points)[n].x(), (*points)[n].y(), (*points)[n].z()); }
};

void expect_openvdb_tables(const std::vector<Point>& points, float voxel)
{
    openvdb::initialize();
    auto transform = openvdb::math::Transform::createLinearTransform(voxel);
    transform->postTranslate(openvdb::Vec3d(0.5 * double(voxel)));
    const auto grid =
        openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(PointArray{&points}, *transform);
    std::vector<const openvdb::tools::PointIndexGrid::TreeType::LeafNodeType*> nodes;
    for (auto leaf = grid->tree().cbeginLeaf(); leaf; ++leaf) nodes.push_back(leaf.getLeaf());
    std::sort(nodes.begin(), nodes.end(), [](const auto* a, const auto* b) { return a->origin() < b->origin(); });

    const PointIndex index(points, {voxel});
    ASSERT_EQ(index.leaves().size(), nodes.size());
    for (std::size_t l = 0; l < nodes.size(); ++l) {
        const PointIndexLeaf& leaf = index.leaves()[l];
        std::uint32_t v = leaf.voxel_begin;
        for (auto value = nodes[l]->cbeginValueOn(); value; ++value, ++v) {
            ASSERT_LT(v, leaf.voxel_end) << "leaf " << l;
            using Value = openvdb::tools::PointIndexGrid::ValueType;
            const Value* begin = nullptr;
            const Value* end = nullptr;
            nodes[l]->getIndices(value.pos(), begin, end);
            std::vector<std::uint32_t> expected(begin, end);
            std::sort(expected.begin(), expected.end());
            const PointIndexVoxel& ours = index.voxels()[v];
            const std::vector<std::uint32_t> found(index.point_order().begin() + ours.begin,
                                                   index.point_order().begin() + ours.end);
            ASSERT_EQ(found, expected) << "leaf " << l << " voxel offset " << value.pos();
        }
        EXPECT_EQ(v, leaf.voxel_end) << "leaf " << l;
    }

    // The sort cuts its input into blocks by the thread count; being stable, it gives one order.
    const tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    const PointIndex serial(points, {voxel});
    EXPECT_TRUE(std::equal(serial.point_order().begin(), serial.point_order().end(), index.point_order().begin(),
                           index.point_order().end()));
}

TEST(PointIndex, TablesMatchOpenVdbBuilder)
{
    // Enough points for several sort blocks; a quarter on the 5 cm lattice, so on voxel faces
    // where the conversion rounds.
    const auto points = test::random_points(70000, 17);
    expect_openvdb_tables(points, 0.05f);
    expect_openvdb_tables(points, 0.013f);
}

TEST(PointIndex, WideSparseCloudMatchesOpenVdbBuilder)
{
    // 10 km x 10 km x 1 km at 1 cm voxels: the (leaf, voxel) key and the point index no longer
    // share a 64-bit word.
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::vector<Point> points(300);
    for (Point& p : points) p = Point(1e4f * unit(rng) - 5e3f, 1e4f * unit(rng), 1e3f * unit(rng));
    expect_openvdb_tables(points, 0.01f);
}

TEST(PointIndex, RejectsPointsItCannotBucket)
{
    auto points = test::random_points(10, 1);
    points[3].y() = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW(PointIndex(points, {0.01f}), Error);
    points[3].y() = std::numeric_limits<float>::infinity();
    EXPECT_THROW(PointIndex(points, {0.01f}), Error);
    points[3].y() = 1e30f;
    EXPECT_THROW(PointIndex(points, {0.01f}), Error);
    points[3].y() = 2e6f;  // 2e9 voxels of 1 mm out: beyond the index's 2^30
    EXPECT_THROW(PointIndex(points, {0.001f}), Error);
}

TEST(PointIndex, StraysOnEveryAxisMatchOpenVdbBuilder)
{
    // Leaves too many to number in 64 bits between the strays (2e9 voxels on each axis): the
    // index sorts by leaf coordinates instead, into the same tables.
    auto points = test::random_points(3000, 3);
    points.emplace_back(-1e6f, -1e6f, -1e6f);
    points.emplace_back(1e6f, 1e6f, 1e6f);
    points.emplace_back(1e6f, -1e6f, 0.5f);
    points.emplace_back(1e6f + 0.0625f, -1e6f, 0.5f);  // 62 voxels beside the last
    expect_openvdb_tables(points, 0.001f);
    const PointIndex index(points, {0.001f});
    EXPECT_EQ(index.point_order().size(), points.size());
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
