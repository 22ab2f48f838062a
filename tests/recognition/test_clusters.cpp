// The components automatic placement splits a scene into, held against their definition: every
// pair of members tested by distance, joined by a plain union-find. The cells the kernel searches
// through must change nothing, including for points that rounding puts on a cell's far side.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "../../recognition/src/clusters.hpp"

namespace mfpc {
namespace {

using Components = std::vector<std::vector<std::uint32_t>>;

// The definition, in O(n^2): members i and j are linked when |p_i - p_j| <= gap on every axis.
Components components_by_pairs(const std::vector<Point>& points, const std::vector<std::uint32_t>& members,
                               float gap)
{
    std::vector<std::uint32_t> parent(members.size());
    std::iota(parent.begin(), parent.end(), 0u);
    auto root = [&](std::uint32_t i) {
        while (parent[i] != i) i = parent[i];
        return i;
    };
    for (std::uint32_t i = 0; i < members.size(); ++i)
        for (std::uint32_t j = i + 1; j < members.size(); ++j) {
            const Point d = (points[members[j]] - points[members[i]]).cwiseAbs();
            if (d.x() <= gap && d.y() <= gap && d.z() <= gap) parent[std::max(root(i), root(j))] = std::min(root(i), root(j));
        }
    Components components;
    std::vector<std::int64_t> slot(members.size(), -1);
    for (std::uint32_t i = 0; i < members.size(); ++i) {
        const std::uint32_t r = root(i);
        if (slot[r] < 0) {
            slot[r] = std::int64_t(components.size());
            components.emplace_back();
        }
        components[std::size_t(slot[r])].push_back(members[i]);
    }
    return components;
}

void expect_definition(const std::vector<Point>& points, const std::vector<std::uint32_t>& members, float gap)
{
    EXPECT_EQ(detail::clusters_of(points, members, gap), components_by_pairs(points, members, gap))
        << members.size() << " members, gap " << gap;
}

std::vector<std::uint32_t> all_of(const std::vector<Point>& points)
{
    std::vector<std::uint32_t> members(points.size());
    std::iota(members.begin(), members.end(), 0u);
    return members;
}

TEST(Clusters, RandomCloudsGiveTheComponentsOfThePairwiseTest)
{
    std::mt19937 random(7);
    for (const float gap : {0.01f, 0.03f, 0.1f, 0.37f}) {
        for (int trial = 0; trial < 4; ++trial) {
            std::uniform_real_distribution<float> coordinate(-1.0f, 1.0f);
            std::vector<Point> points(600);
            for (Point& p : points) p = Point(coordinate(random), coordinate(random), coordinate(random) * 0.2f);
            // A subset in shuffled order too: members need not be sorted or cover the cloud.
            std::vector<std::uint32_t> members = all_of(points);
            std::shuffle(members.begin(), members.end(), random);
            members.resize(400);
            expect_definition(points, all_of(points), gap);
            expect_definition(points, members, gap);
        }
    }
}

// Coordinates a few ulps either side of multiples of the gap, negative ones included: where the
// division that picks a point's cell and the subtraction of the test round differently.
TEST(Clusters, PointsOnCellFacesJoinExactlyAsTheTestSays)
{
    std::mt19937 random(11);
    for (const float gap : {0.1f, 0.3f, 0.007f, 1.0f / 3.0f}) {
        std::uniform_int_distribution<int> multiple(-6, 6), ulps(-3, 3), axis(0, 2);
        auto near_face = [&] {
            float x = float(multiple(random)) * gap;
            for (int u = ulps(random); u != 0; u += u > 0 ? -1 : 1)
                x = std::nextafter(x, u > 0 ? INFINITY : -INFINITY);
            return x;
        };
        std::vector<Point> points(500);
        for (Point& p : points) p = Point(near_face(), near_face(), near_face());
        expect_definition(points, all_of(points), gap);
        // Pairs exactly one gap apart, give or take an ulp, along one axis.
        std::vector<Point> pairs;
        for (int k = 0; k < 200; ++k) {
            Point a(near_face(), near_face(), near_face());
            Point b = a;
            float& c = b[axis(random)];
            c = c + gap;
            if (k % 3 == 1) c = std::nextafter(c, INFINITY);
            if (k % 3 == 2) c = std::nextafter(c, -INFINITY);
            pairs.push_back(a);
            pairs.push_back(b);
        }
        expect_definition(pairs, all_of(pairs), gap);
    }
}

TEST(Clusters, ChainsAcrossManyCellsAreOneComponent)
{
    std::vector<Point> points;
    for (int i = 0; i < 300; ++i) points.emplace_back(0.0099f * float(i), 0.004f * float(i % 3), -0.5f);
    const Components components = detail::clusters_of(points, all_of(points), 0.01f);
    ASSERT_EQ(components.size(), 1u);
    EXPECT_EQ(components[0], all_of(points));
    expect_definition(points, all_of(points), 0.01f);
}

// Quotients past 2^31 cells: the cells grow with the cloud's extent, and stay exact.
TEST(Clusters, FarPointsAndTinyGapsStayExact)
{
    std::mt19937 random(5);
    for (const float far : {1.0e3f, 1.0e6f, 3.0e8f}) {
        std::uniform_real_distribution<float> coordinate(-far, far);
        std::vector<Point> points;
        for (int i = 0; i < 150; ++i) {
            const Point p(coordinate(random), coordinate(random), coordinate(random));
            points.push_back(p);
            // A neighbour one ulp to a few ulps away, so that components are not all single points.
            points.emplace_back(std::nextafter(p.x(), INFINITY), p.y(), std::nextafter(p.z(), -INFINITY));
        }
        const float ulp = std::nextafter(far, INFINITY) - far;
        for (const float gap : {far * 1e-10f, ulp * 0.5f, ulp, ulp * 4.0f, far * 1e-3f})
            expect_definition(points, all_of(points), gap);
    }
}

TEST(Clusters, NoMembersAndOneMember)
{
    const std::vector<Point> points{Point(1, 2, 3), Point(1, 2, 3)};
    EXPECT_TRUE(detail::clusters_of(points, {}, 0.1f).empty());
    const std::vector<std::uint32_t> one{1};
    EXPECT_EQ(detail::clusters_of(points, one, 0.1f), Components{{1}});
    // Coincident points are one component at any gap.
    EXPECT_EQ(detail::clusters_of(points, all_of(points), 1e-6f), (Components{{0, 1}}));
}

}  // namespace
}  // namespace mfpc
