#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "mfpc/core/error.hpp"
#include "mfpc/core/foveated_structure.hpp"

namespace mfpc {
namespace {

FoveatedStructure make_structure(Eigen::Vector3f outer_min, Eigen::Vector3f outer_size,
                                 Eigen::Vector3f fovea_size, Eigen::Vector3f fovea_offset, int levels)
{
    FoveatedStructure structure;
    structure.outer_min = outer_min;
    structure.outer_size = outer_size;
    structure.fovea_size = fovea_size;
    structure.fovea_offset = fovea_offset;
    structure.levels = levels;
    return structure;
}

void expect_box(const Box& box, Eigen::Vector3f min, Eigen::Vector3f max)
{
    for (int axis = 0; axis < 3; ++axis) {
        EXPECT_EQ(box.min[axis], min[axis]) << "min axis " << axis;
        EXPECT_EQ(box.max[axis], max[axis]) << "max axis " << axis;
    }
}

// Eq. 7 and 8 in long double, for structures whose values are not exact in binary.
Box formula_box(const FoveatedStructure& s, int k)
{
    Box box;
    const long double m = s.levels;
    for (int axis = 0; axis < 3; ++axis) {
        const long double s0 = s.outer_size[axis];
        const long double sm = s.fovea_size[axis];
        const long double f = s.fovea_offset[axis];
        const long double size = (k * (sm - s0) + m * s0) / m;
        const long double offset = k * (s0 - sm + 2 * f) / (2 * m);
        box.min[axis] = float(s.outer_min[axis] + offset);
        box.max[axis] = float(s.outer_min[axis] + offset + size);
    }
    return box;
}

TEST(FoveatedStructure, OneLevelIsOuterAndFovea)
{
    // m = 1, F at -limit on y, +limit on z, inside on x: box 1 is the fovea box itself.
    const auto s = make_structure({0, 0, 0}, {2, 4, 8}, {1, 1, 1}, {0.25f, -1.5f, 3.5f}, 1);
    expect_box(s.level_box(0), {0, 0, 0}, {2, 4, 8});
    expect_box(s.level_box(1), {0.75f, 0, 7}, {1.75f, 1, 8});
}

TEST(FoveatedStructure, TwoLevelsCentredHandComputed)
{
    // S_1 = (1 (2 - 4) + 2 * 4) / 2 = 3, δ_1 = 1 (4 - 2 + 0) / 4 = 0.5; S_2 = 2, δ_2 = 1.
    const auto s = make_structure({0, 0, 0}, {4, 4, 4}, {2, 2, 2}, {0, 0, 0}, 2);
    expect_box(s.level_box(0), {0, 0, 0}, {4, 4, 4});
    expect_box(s.level_box(1), {0.5f, 0.5f, 0.5f}, {3.5f, 3.5f, 3.5f});
    expect_box(s.level_box(2), {1, 1, 1}, {3, 3, 3});
}

TEST(FoveatedStructure, TwoLevelsFoveaAtTheLimitHandComputed)
{
    // F = (+1, 0, -1) with limit 1: the boxes touch the outer box's max face on x and min face on z.
    // x: δ_1 = (4 - 2 + 2) / 4 = 1, δ_2 = 2; z: δ_k = 0.
    const auto s = make_structure({0, 0, 0}, {4, 4, 4}, {2, 2, 2}, {1, 0, -1}, 2);
    EXPECT_EQ(s.fovea_offset_limit(), Eigen::Vector3f(1, 1, 1));
    expect_box(s.level_box(1), {1, 0.5f, 0}, {4, 3.5f, 3});
    expect_box(s.level_box(2), {2, 1, 0}, {4, 3, 2});
}

TEST(FoveatedStructure, ThreeLevelsOffsetOriginHandComputed)
{
    // S_k = 6 - k, δ_k = k / 2.
    const auto s = make_structure({-1, 2, 0.5f}, {6, 6, 6}, {3, 3, 3}, {0, 0, 0}, 3);
    expect_box(s.level_box(0), {-1, 2, 0.5f}, {5, 8, 6.5f});
    expect_box(s.level_box(1), {-0.5f, 2.5f, 1}, {4.5f, 7.5f, 6});
    expect_box(s.level_box(2), {0, 3, 1.5f}, {4, 7, 5.5f});
    expect_box(s.level_box(3), {0.5f, 3.5f, 2}, {3.5f, 6.5f, 5});
}

TEST(FoveatedStructure, ThreeLevelsOffsetFoveaHandComputed)
{
    // F = (-1.5, 0.75, 1.5) with limit 1.5: δ_k = k (3 + 2F) / 6 = (0, 0.75 k, k).
    const auto s = make_structure({0, 0, 0}, {6, 6, 6}, {3, 3, 3}, {-1.5f, 0.75f, 1.5f}, 3);
    expect_box(s.level_box(1), {0, 0.75f, 1}, {5, 5.75f, 6});
    expect_box(s.level_box(2), {0, 1.5f, 2}, {4, 5.5f, 6});
    expect_box(s.level_box(3), {0, 2.25f, 3}, {3, 5.25f, 6});
}

TEST(FoveatedStructure, InexactValuesFollowTheFormula)
{
    const auto s = make_structure({-0.288f, -0.463f, 0.5525f}, {0.45f, 0.65f, 0.5f},
                                  {0.2f, 0.3f, 0.22f}, {0.01f, -0.02f, 0.03f}, 3);
    const Box outer = s.outer_box();
    expect_box(s.level_box(0), outer.min, outer.max);
    for (int k = 0; k <= 3; ++k) {
        const Box expected = formula_box(s, k);
        const Box box = s.level_box(k);
        for (int axis = 0; axis < 3; ++axis) {
            // One rounding to float: within an ulp of the exact corner.
            EXPECT_NEAR(box.min[axis], expected.min[axis], 1.2e-7) << "k " << k;
            EXPECT_NEAR(box.max[axis], expected.max[axis], 1.2e-7) << "k " << k;
        }
    }
    const Box fovea = s.level_box(3);
    EXPECT_TRUE(fovea.center().isApprox(s.fovea_center(), 1e-6f));
    EXPECT_TRUE(fovea.size().isApprox(s.fovea_size, 1e-6f));
}

TEST(FoveatedStructure, FoveaBoxIsCentredAtTheFoveaCentre)
{
    for (int m = 1; m <= 4; ++m) {
        const auto s = make_structure({-2, 0, 1}, {4, 8, 2}, {1, 2, 0.5f}, {1, -2, 0.25f}, m);
        expect_box(s.level_box(m), {0.5f, 1, 2}, {1.5f, 3, 2.5f});
        EXPECT_EQ(s.level_box(m).center(), s.fovea_center());
    }
}

TEST(FoveatedStructure, BoxesAreNestedForRandomStructures)
{
    for (unsigned seed = 1; seed <= 200; ++seed) {
        std::mt19937 random(seed);
        std::uniform_real_distribution<float> coordinate(-3.0f, 3.0f);
        std::uniform_real_distribution<float> size(0.01f, 2.0f);
        std::uniform_real_distribution<float> fraction(0.0f, 1.0f);
        std::uniform_int_distribution<int> levels(1, 6);
        std::uniform_int_distribution<int> where(0, 2);
        FoveatedStructure s;
        s.levels = levels(random);
        for (int axis = 0; axis < 3; ++axis) {
            s.outer_min[axis] = coordinate(random);
            s.outer_size[axis] = size(random);
            s.fovea_size[axis] = s.outer_size[axis] * std::max(fraction(random), 0.01f);
        }
        const Eigen::Vector3f limit = s.fovea_offset_limit();
        for (int axis = 0; axis < 3; ++axis) {
            // Half the axes sit exactly at a limit, where rounding is most likely to break nesting.
            const int choice = where(random);
            s.fovea_offset[axis] = choice == 0   ? limit[axis]
                                   : choice == 1 ? -limit[axis]
                                                 : limit[axis] * (2 * fraction(random) - 1);
        }
        const Box outer = s.outer_box();
        expect_box(s.level_box(0), outer.min, outer.max);
        for (int k = 0; k < s.levels; ++k) {
            const Box box = s.level_box(k);
            const Box inner = s.level_box(k + 1);
            EXPECT_TRUE(box.valid()) << "seed " << seed << " k " << k;
            EXPECT_TRUE(box.contains(inner)) << "seed " << seed << " k " << k;
        }
    }
}

TEST(FoveatedStructure, DensityAndRadiusInterpolate)
{
    FoveatedStructure s;
    s.levels = 3;
    s.density_outer = 0.02f;
    s.density_fovea = 0.005f;
    s.keypoint_radius_outer = 0.03f;
    s.keypoint_radius_fovea = 0.01f;
    EXPECT_EQ(s.density(0), 0.02f);
    EXPECT_FLOAT_EQ(s.density(1), 0.015f);
    EXPECT_FLOAT_EQ(s.density(2), 0.01f);
    EXPECT_EQ(s.density(3), 0.005f);
    EXPECT_EQ(s.keypoint_radius(0), 0.03f);
    EXPECT_FLOAT_EQ(s.keypoint_radius(1), 0.03f - 0.02f / 3);
    EXPECT_FLOAT_EQ(s.keypoint_radius(2), 0.03f - 0.04f / 3);
    EXPECT_EQ(s.keypoint_radius(3), 0.01f);

    s.levels = 1;
    EXPECT_EQ(s.density(0), 0.02f);
    EXPECT_EQ(s.density(1), 0.005f);

    // Density 0 keeps every point on every level; growing densities are allowed too.
    s.levels = 4;
    s.density_outer = 0.0f;
    s.density_fovea = 0.0f;
    for (int k = 0; k <= 4; ++k) EXPECT_EQ(s.density(k), 0.0f);
    s.density_fovea = 0.04f;
    EXPECT_EQ(s.density(2), 0.02f);
}

TEST(FoveatedStructure, DensitiesAreMonotoneBetweenTheEnds)
{
    FoveatedStructure s;
    s.levels = 7;
    s.density_outer = 0.033f;
    s.density_fovea = 0.0031f;
    for (int k = 0; k < 7; ++k) EXPECT_GT(s.density(k), s.density(k + 1)) << k;
}

TEST(FoveatedStructure, LevelOfFacePoints)
{
    // Boxes [0,4], [0.5,3.5], [1,3] per axis: a point on a face of box k is inside box k.
    const auto s = make_structure({0, 0, 0}, {4, 4, 4}, {2, 2, 2}, {0, 0, 0}, 2);
    EXPECT_EQ(s.level_of({2, 2, 2}), 2);
    EXPECT_EQ(s.level_of({1, 2, 2}), 2);      // min face of the fovea
    EXPECT_EQ(s.level_of({3, 3, 3}), 2);      // max corner of the fovea
    EXPECT_EQ(s.level_of({0.5f, 2, 2}), 1);   // min face of box 1
    EXPECT_EQ(s.level_of({2, 3.5f, 2}), 1);   // max face of box 1
    EXPECT_EQ(s.level_of({3.25f, 2, 2}), 1);  // between box 2 and box 1's faces
    EXPECT_EQ(s.level_of({0, 0, 0}), 0);      // outer corner
    EXPECT_EQ(s.level_of({4, 2, 2}), 0);      // outer max face
    EXPECT_EQ(s.level_of({std::nextafter(0.5f, 0.0f), 2, 2}), 0);
    EXPECT_EQ(s.level_of({std::nextafter(4.0f, 5.0f), 2, 2}), -1);
    EXPECT_EQ(s.level_of({2, 2, -1}), -1);
}

TEST(FoveatedStructure, LevelOfWithFoveaAtTheLimit)
{
    // x at +limit: every box shares the outer max face x = 4, so a point there is in the fovea.
    const auto s = make_structure({0, 0, 0}, {4, 4, 4}, {2, 2, 2}, {1, 0, 0}, 2);
    EXPECT_EQ(s.level_of({4, 2, 2}), 2);
    EXPECT_EQ(s.level_of({1.5f, 2, 2}), 1);
    EXPECT_EQ(s.level_of({0.5f, 2, 2}), 0);
}

TEST(FoveatedStructure, SetFoveaCenterRoundTrip)
{
    auto s = make_structure({-1, 0, 2}, {4, 2, 8}, {1, 1, 1}, {0, 0, 0}, 3);
    EXPECT_EQ(s.fovea_center(), Eigen::Vector3f(1, 1, 6));
    s.set_fovea_center({2.25f, 0.5f, 3});
    EXPECT_EQ(s.fovea_offset, Eigen::Vector3f(1.25f, -0.5f, -3));
    EXPECT_EQ(s.fovea_center(), Eigen::Vector3f(2.25f, 0.5f, 3));
    EXPECT_EQ(s.level_box(3).center(), Eigen::Vector3f(2.25f, 0.5f, 3));

    // Values that are not exact in binary come back within rounding.
    auto t = make_structure({-0.288f, -0.463f, 0.5525f}, {0.45f, 0.65f, 0.5f}, {0.2f, 0.3f, 0.22f},
                            {0, 0, 0}, 3);
    const Eigen::Vector3f center(-0.063f, -0.138f, 0.8025f);
    t.set_fovea_center(center);
    EXPECT_TRUE(t.fovea_center().isApprox(center, 1e-6f));
    EXPECT_TRUE(t.level_box(3).center().isApprox(center, 1e-6f));
}

TEST(FoveatedStructure, FoveaOffsetLimit)
{
    const auto s = make_structure({0, 0, 0}, {4, 3, 1}, {2, 1, 1}, {0, 0, 0}, 3);
    EXPECT_EQ(s.fovea_offset_limit(), Eigen::Vector3f(1, 1, 0));
}

TEST(FoveatedStructure, InvalidStructuresAndLevelsThrow)
{
    const auto s = make_structure({0, 0, 0}, {4, 4, 4}, {2, 2, 2}, {0, 0, 0}, 2);
    EXPECT_THROW(s.level_box(-1), Error);
    EXPECT_THROW(s.level_box(3), Error);
    EXPECT_THROW(s.density(3), Error);
    EXPECT_THROW(s.keypoint_radius(-1), Error);

    auto no_levels = s;
    no_levels.levels = 0;
    EXPECT_THROW(no_levels.level_box(0), Error);
    EXPECT_THROW(no_levels.level_of({1, 1, 1}), Error);

    auto big_fovea = s;
    big_fovea.fovea_size = {5, 2, 2};
    EXPECT_THROW(big_fovea.level_box(1), Error);

    auto flat = s;
    flat.outer_size = {4, 0, 4};
    EXPECT_THROW(flat.level_box(0), Error);

    auto poking = s;
    poking.fovea_offset = {0, 1.5f, 0};
    try {
        poking.level_box(2);
        FAIL() << "a fovea outside its outer box was accepted";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("fovea offset y"), std::string::npos) << error.what();
    }

    auto named = poking;
    named.name = "carton";
    try {
        named.level_box(2);
        FAIL();
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.where()).find("carton"), std::string::npos) << error.what();
    }

    auto not_finite = s;
    not_finite.outer_min.x() = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW(not_finite.level_box(0), Error);
}

}  // namespace
}  // namespace mfpc
