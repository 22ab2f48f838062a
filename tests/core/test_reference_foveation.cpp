#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <set>
#include <span>
#include <vector>

#include <gtest/gtest.h>

#include "mfpc/core/foveated_structure.hpp"
#include "reference_foveation.hpp"

namespace mfpc {
namespace {

using reference::RawLabel;

FoveatedStructure box_structure(Eigen::Vector3f outer_min, Eigen::Vector3f outer_size,
                                Eigen::Vector3f fovea_size, int levels, float density_outer,
                                float density_fovea)
{
    FoveatedStructure structure;
    structure.outer_min = outer_min;
    structure.outer_size = outer_size;
    structure.fovea_size = fovea_size;
    structure.levels = levels;
    structure.density_outer = density_outer;
    structure.density_fovea = density_fovea;
    return structure;
}

// A random valid structure inside [-1, 1]^3 (roughly), sharing m with its config.
FoveatedStructure random_structure(std::mt19937& random, int levels)
{
    std::uniform_real_distribution<float> coordinate(-1.0f, 0.5f);
    std::uniform_real_distribution<float> size(0.1f, 1.2f);
    std::uniform_real_distribution<float> fraction(0.05f, 1.0f);
    std::uniform_real_distribution<float> density(0.0f, 0.03f);
    FoveatedStructure s;
    s.levels = levels;
    for (int axis = 0; axis < 3; ++axis) {
        s.outer_min[axis] = coordinate(random);
        s.outer_size[axis] = size(random);
        s.fovea_size[axis] = s.outer_size[axis] * fraction(random);
    }
    const Eigen::Vector3f limit = s.fovea_offset_limit();
    for (int axis = 0; axis < 3; ++axis) {
        // A quarter of the axes put the fovea exactly at a limit, on the outer box's face.
        const unsigned choice = random() % 8;
        s.fovea_offset[axis] = choice == 0   ? limit[axis]
                               : choice == 1 ? -limit[axis]
                                             : limit[axis] * (2 * fraction(random) - 1);
    }
    // Some structures keep every point (density 0) or have equal densities on every level.
    switch (random() % 4) {
    case 0: s.density_outer = 0.0f; s.density_fovea = 0.0f; break;
    case 1: s.density_outer = s.density_fovea = density(random); break;
    default: s.density_outer = density(random); s.density_fovea = density(random); break;
    }
    return s;
}

// Random points over [-1.2, 1.2]^3, plus points exactly on the faces and corners of every level
// box, where an off-by-one-ulp box would show.
std::vector<Point> random_points(std::mt19937& random, std::span<const FoveatedStructure> structures,
                                 std::size_t count)
{
    std::uniform_real_distribution<float> coordinate(-1.2f, 1.2f);
    std::uniform_real_distribution<float> fraction(0.0f, 1.0f);
    std::vector<Point> points;
    for (std::size_t i = 0; i < count; ++i) {
        points.emplace_back(coordinate(random), coordinate(random), coordinate(random));
    }
    for (const FoveatedStructure& s : structures) {
        for (int k = 0; k <= s.levels; ++k) {
            const Box box = s.level_box(k);
            points.push_back(box.min);
            points.push_back(box.max);
            for (int axis = 0; axis < 3; ++axis) {
                for (int side = 0; side < 2; ++side) {
                    Point p = box.min + (box.max - box.min).cwiseProduct(Point(
                                            fraction(random), fraction(random), fraction(random)));
                    p[axis] = side ? box.max[axis] : box.min[axis];
                    points.push_back(p);
                    p[axis] = std::nextafter(p[axis], side ? 10.0f : -10.0f);  // just outside
                    points.push_back(p);
                }
            }
        }
    }
    return points;
}

struct Scene {
    std::vector<FoveatedStructure> structures;
    std::vector<Point> points;
};

Scene random_scene(unsigned seed)
{
    std::mt19937 random(seed);
    Scene scene;
    const int levels = 1 + int(random() % 5);
    const std::size_t count = 1 + random() % 4;
    for (std::size_t j = 0; j < count; ++j) scene.structures.push_back(random_structure(random, levels));
    scene.points = random_points(random, scene.structures, 2000);
    return scene;
}

TEST(ReferenceFoveation, SingleLevelsAgreeWithLevelOf)
{
    for (unsigned seed = 1; seed <= 40; ++seed) {
        const Scene scene = random_scene(seed);
        for (const FoveatedStructure& s : scene.structures) {
            const std::vector<int> levels = reference::reference_single_levels(scene.points, s);
            ASSERT_EQ(levels.size(), scene.points.size());
            for (std::size_t i = 0; i < scene.points.size(); ++i) {
                ASSERT_EQ(levels[i], s.level_of(scene.points[i])) << "seed " << seed << " point " << i;
            }
        }
    }
}

TEST(ReferenceFoveation, SingleLevelsHandExample)
{
    // Boxes [0,4], [0.5,3.5], [1,3] per axis.
    const auto s = box_structure({0, 0, 0}, {4, 4, 4}, {2, 2, 2}, 2, 0.02f, 0.005f);
    const std::vector<Point> points = {{2, 2, 2}, {0.5f, 2, 2}, {0.25f, 2, 2}, {5, 2, 2}, {1, 1, 1}};
    EXPECT_EQ(reference::reference_single_levels(points, s), (std::vector<int>{2, 1, 0, -1, 2}));
}

TEST(ReferenceFoveation, MfpcLabelsKeepEachPointAtItsDensestLevel)
{
    for (unsigned seed = 1; seed <= 40; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        const Scene scene = random_scene(seed);
        const auto labels = reference::reference_mfpc_labels(scene.points, scene.structures);
        ASSERT_EQ(labels.size(), scene.points.size());
        std::vector<std::vector<int>> single;
        for (const auto& s : scene.structures) {
            single.push_back(reference::reference_single_levels(scene.points, s));
        }
        for (std::size_t i = 0; i < scene.points.size(); ++i) {
            const RegionLabel label = labels[i];
            bool covered = false;
            for (const auto& levels : single) covered = covered || levels[i] >= 0;
            ASSERT_EQ(label.structure >= 0, covered) << "point " << i;
            ASSERT_EQ(label.level >= 0, covered) << "point " << i;
            if (!covered) continue;
            // The chosen structure covers the point at the chosen level ...
            ASSERT_EQ(single[label.structure][i], label.level) << "point " << i;
            // ... and no covering structure has a denser level for it.
            const float density = scene.structures[label.structure].density(label.level);
            for (std::size_t j = 0; j < single.size(); ++j) {
                const int level = single[j][i];
                if (level < 0) continue;
                const float other = scene.structures[j].density(level);
                ASSERT_GE(other, density) << "point " << i << " structure " << j;
                if (other == density) {
                    ASSERT_TRUE(level < label.level ||
                                (level == label.level && int(j) >= label.structure))
                        << "point " << i << " structure " << j;
                }
            }
        }
    }
}

TEST(ReferenceFoveation, RawIsTheConcatenationOfSingles)
{
    for (unsigned seed = 1; seed <= 40; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        const Scene scene = random_scene(seed);
        const auto raw = reference::reference_raw_labels(scene.points, scene.structures);
        std::vector<RawLabel> concatenated;
        for (std::size_t j = 0; j < scene.structures.size(); ++j) {
            const auto levels = reference::reference_single_levels(scene.points, scene.structures[j]);
            for (std::size_t i = 0; i < levels.size(); ++i) {
                if (levels[i] >= 0) {
                    concatenated.push_back(
                        {std::uint32_t(i), {std::int16_t(j), std::int16_t(levels[i])}});
                }
            }
        }
        // |raw| = Σ |single_j|, in structure order.
        EXPECT_EQ(raw, concatenated);

        // The treated output is a subset of the raw one, each point once.
        const auto labels = reference::reference_mfpc_labels(scene.points, scene.structures);
        std::set<std::pair<std::uint32_t, std::pair<int, int>>> raw_set;
        for (const RawLabel& entry : raw) {
            raw_set.insert({entry.point, {entry.label.structure, entry.label.level}});
        }
        std::size_t kept = 0;
        for (std::size_t i = 0; i < labels.size(); ++i) {
            if (labels[i].structure < 0) continue;
            ++kept;
            EXPECT_TRUE(raw_set.count({std::uint32_t(i), {labels[i].structure, labels[i].level}}))
                << "point " << i;
        }
        EXPECT_LE(kept, raw.size());
        std::set<std::uint32_t> raw_points;
        for (const RawLabel& entry : raw) raw_points.insert(entry.point);
        EXPECT_EQ(kept, raw_points.size());
    }
}

TEST(ReferenceFoveation, OverlapHandExample)
{
    // A: boxes [0,4], [1,3] (m = 1), d = 0.02 then 0.005. B: [2,6], [3,5], d = 0.01 then 0.001.
    const auto a = box_structure({0, 0, 0}, {4, 4, 4}, {2, 2, 2}, 1, 0.02f, 0.005f);
    const auto b = box_structure({2, 2, 2}, {4, 4, 4}, {2, 2, 2}, 1, 0.01f, 0.001f);
    const std::vector<FoveatedStructure> structures = {a, b};
    const std::vector<Point> points = {
        {0.5f, 0.5f, 0.5f},  // A level 0 only
        {2.5f, 2.5f, 2.5f},  // A fovea (0.005) and B outer (0.01): A's fovea
        {3.5f, 3.5f, 3.5f},  // A outer (0.02) and B fovea (0.001): B's fovea
        {3, 3, 3},           // on both foveae's faces: B's fovea, the denser
        {5.5f, 5.5f, 5.5f},  // B level 0 only
        {7, 7, 7},           // nowhere
    };
    const auto labels = reference::reference_mfpc_labels(points, structures);
    const std::vector<RegionLabel> expected = {{0, 0}, {0, 1}, {1, 1}, {1, 1}, {1, 0}, {-1, -1}};
    EXPECT_EQ(labels, expected);

    const auto raw = reference::reference_raw_labels(points, structures);
    const std::vector<RawLabel> expected_raw = {{0, {0, 0}}, {1, {0, 1}}, {2, {0, 0}}, {3, {0, 1}},
                                                {1, {1, 0}}, {2, {1, 1}}, {3, {1, 1}}, {4, {1, 0}}};
    EXPECT_EQ(raw, expected_raw);
}

TEST(ReferenceFoveation, TiesGoToTheHigherLevelThenTheEarlierStructure)
{
    // Equal densities everywhere: the higher level wins, then the lower structure index.
    const auto a = box_structure({0, 0, 0}, {4, 4, 4}, {2, 2, 2}, 1, 0.01f, 0.01f);
    const auto b = box_structure({0, 0, 0}, {4, 4, 4}, {2, 2, 2}, 1, 0.01f, 0.01f);
    const auto c = box_structure({1, 1, 1}, {6, 6, 6}, {1, 1, 1}, 1, 0.01f, 0.01f);
    const std::vector<FoveatedStructure> structures = {c, a, b};
    const std::vector<Point> points = {
        {0.5f, 0.5f, 0.5f},  // a and b level 0: a (index 1)
        {2, 2, 2},           // a, b level 1; c level 0: a (level 1, index 1)
        {4, 4, 4},           // a, b level 0 (face); c level 1 (its fovea [3.5, 4.5]): c
    };
    const auto labels = reference::reference_mfpc_labels(points, structures);
    const std::vector<RegionLabel> expected = {{1, 0}, {1, 1}, {0, 1}};
    EXPECT_EQ(labels, expected);
}

TEST(ReferenceFoveation, DensityZeroIsTheDensest)
{
    // A keeps every point (d = 0) on its outer level; B's fovea (d = 0.001) does not win there.
    const auto a = box_structure({0, 0, 0}, {4, 4, 4}, {1, 1, 1}, 2, 0.0f, 0.0f);
    const auto b = box_structure({1, 1, 1}, {2, 2, 2}, {1, 1, 1}, 2, 0.01f, 0.001f);
    const std::vector<FoveatedStructure> structures = {b, a};
    const std::vector<Point> points = {{2, 2, 2}, {0.5f, 0.5f, 0.5f}};
    const auto labels = reference::reference_mfpc_labels(points, structures);
    // (2,2,2) is in both foveae (B's d_2 = 0.001, A's d_2 = 0): A's wins.
    const std::vector<RegionLabel> expected = {{1, 2}, {1, 0}};
    EXPECT_EQ(labels, expected);
}

TEST(ReferenceFoveation, PerAxisContainmentIsWrongWholeBoxIsRight)
{
    // A covers x, z of p and B covers y, z of p, but neither box holds p; C does.
    const auto a = box_structure({0, 0, 0}, {1, 1, 1}, {0.5f, 0.5f, 0.5f}, 2, 0.02f, 0.005f);
    const auto b = box_structure({2, 2, 0}, {1, 1, 1}, {0.5f, 0.5f, 0.5f}, 2, 0.02f, 0.005f);
    const auto c = box_structure({0, 0, 0}, {3, 3, 3}, {1, 1, 1}, 2, 0.02f, 0.005f);
    const std::vector<FoveatedStructure> structures = {a, b, c};
    const Point p(0.5f, 2.5f, 0.5f);
    const std::span<const FoveatedStructure> before(structures.data(), 2);
    EXPECT_TRUE(reference::per_axis_inside_any(p, before));
    EXPECT_FALSE(reference::whole_box_inside_any(p, before));
    EXPECT_FALSE(a.outer_box().contains(p));
    EXPECT_FALSE(b.outer_box().contains(p));

    // The authors' loop drops a point of structure j when it seems inside an earlier structure.
    // With the per-axis test p is dropped from C and so from the output; the reference keeps it.
    const std::vector<Point> points = {p};
    bool kept_by_per_axis = false;
    for (std::size_t j = 0; j < structures.size(); ++j) {
        const std::span<const FoveatedStructure> earlier(structures.data(), j);
        if (structures[j].level_of(p) >= 0 && !reference::per_axis_inside_any(p, earlier)) {
            kept_by_per_axis = true;
        }
    }
    EXPECT_FALSE(kept_by_per_axis);
    const auto labels = reference::reference_mfpc_labels(points, structures);
    // p sits on the faces of C's box 1 ([0.5, 2.5] per axis), outside its fovea [1, 2].
    EXPECT_EQ(labels[0], (RegionLabel{2, 1}));
}

TEST(ReferenceFoveation, VoxelDownsampleHandExample)
{
    const std::vector<Point> points = {
        {0.1f, 0.1f, 0.1f}, {0.3f, 0.3f, 0.3f},     // voxel (0,0,0)
        {-0.1f, 0.2f, 0.2f},                        // voxel (-1,0,0): floor of a negative
        {1.2f, 0.1f, 0.1f},                         // voxel (2,0,0)
        {0.2f, 0.2f, 0.2f},                         // voxel (0,0,0), not in the region
        {0.5f, 0.0f, 0.0f},                         // on the face: voxel (1,0,0)
    };
    const std::vector<std::uint32_t> region = {5, 3, 2, 1, 0};
    const auto result = reference::reference_downsample(points, region, 0.5f, Downsample::voxel);
    ASSERT_EQ(result.points.size(), 4u);
    EXPECT_TRUE(result.indices.empty());
    // Sorted by key: (-1,0,0), (0,0,0), (1,0,0), (2,0,0).
    EXPECT_EQ(result.points[0], points[2]);
    EXPECT_EQ(result.points[1], Point(0.2f, 0.2f, 0.2f));
    EXPECT_EQ(result.points[2], points[5]);
    EXPECT_EQ(result.points[3], points[3]);
}

TEST(ReferenceFoveation, DownsamplingCarriesColours)
{
    // Voxel size 1: points 0, 1, 2 share voxel (0,0,0), point 3 is alone in (1,0,0).
    const std::vector<Point> points = {{0.1f, 0.1f, 0.1f}, {0.5f, 0.5f, 0.5f}, {0.9f, 0.9f, 0.9f}, {1.5f, 0.5f, 0.5f}};
    const std::vector<Rgb> colors = {{255, 0, 10}, {254, 1, 11}, {0, 1, 11}, {7, 8, 9}};
    const std::vector<std::uint32_t> region = {3, 2, 1, 0};
    const auto voxel = reference::reference_downsample(points, region, 1.0f, Downsample::voxel, colors);
    ASSERT_EQ(voxel.colors.size(), 2u);
    // r: 509 / 3 = 169.67 rounds up; g: 2 / 3 = 0.67 rounds up; b: 32 / 3 = 10.67 rounds up.
    EXPECT_EQ(voxel.colors[0], (Rgb{170, 1, 11}));
    EXPECT_EQ(voxel.colors[1], colors[3]);
    const std::vector<std::uint32_t> pair = {0, 1};
    // r: 509 / 2 = 254.5, a half, rounds up; g: 1 / 2 rounds up; b: 21 / 2 rounds up.
    EXPECT_EQ(reference::reference_downsample(points, pair, 1.0f, Downsample::voxel, colors).colors[0],
              (Rgb{255, 1, 11}));

    const auto uniform = reference::reference_downsample(points, region, 1.0f, Downsample::uniform, colors);
    ASSERT_EQ(uniform.indices, (std::vector<std::uint32_t>{1, 3}));
    EXPECT_EQ(uniform.colors, (std::vector<Rgb>{colors[1], colors[3]}));
    EXPECT_TRUE(reference::reference_downsample(points, region, 1.0f, Downsample::voxel).colors.empty());
    const std::vector<Rgb> short_colors(colors.begin(), colors.end() - 1);
    EXPECT_THROW(reference::reference_downsample(points, region, 1.0f, Downsample::voxel, short_colors), Error);
}

TEST(ReferenceFoveation, UniformDownsampleKeepsTheOriginalPointNearestTheCentre)
{
    // Voxel size 1: centres at (k + 0.5). Points 0 and 2 are equally far from (0.5,0.5,0.5).
    const std::vector<Point> points = {
        {0.25f, 0.5f, 0.5f}, {0.9f, 0.9f, 0.9f}, {0.75f, 0.5f, 0.5f}, {1.5f, 0.5f, 0.5f},
        {1.0f, 0.2f, 0.2f},  {-0.5f, -0.5f, -0.5f}};
    const std::vector<std::uint32_t> region = {4, 3, 2, 1, 0, 5};
    const auto result = reference::reference_downsample(points, region, 1.0f, Downsample::uniform);
    EXPECT_EQ(result.indices, (std::vector<std::uint32_t>{0, 3, 5}));
    ASSERT_EQ(result.points.size(), 3u);
    EXPECT_EQ(result.points[1], points[3]);
}

TEST(ReferenceFoveation, DensityZeroKeepsEveryPoint)
{
    const std::vector<Point> points = {{0, 0, 0}, {0, 0, 0}, {1, 2, 3}};
    const std::vector<std::uint32_t> region = {2, 0, 1};
    for (Downsample mode : {Downsample::voxel, Downsample::uniform}) {
        const auto result = reference::reference_downsample(points, region, 0.0f, mode);
        EXPECT_EQ(result.indices, (std::vector<std::uint32_t>{0, 1, 2}));
        EXPECT_EQ(result.points, points);
    }
    EXPECT_THROW(reference::reference_downsample(points, region, -0.1f, Downsample::voxel), Error);
    const std::vector<std::uint32_t> twice = {0, 0};
    EXPECT_THROW(reference::reference_downsample(points, twice, 0.1f, Downsample::voxel), Error);
}

TEST(ReferenceFoveation, RandomDownsampleProperties)
{
    for (unsigned seed = 1; seed <= 20; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        std::mt19937 random(seed);
        std::uniform_real_distribution<float> coordinate(-0.3f, 0.3f);
        std::vector<Point> points(3000);
        for (Point& p : points) p = Point(coordinate(random), coordinate(random), coordinate(random));
        std::vector<std::uint32_t> region;
        for (std::uint32_t i = 0; i < points.size(); ++i) {
            if (random() % 3) region.push_back(i);
        }
        const float d = 0.01f + 0.05f * float(seed % 5);
        std::set<reference::VoxelKey> keys;
        for (std::uint32_t i : region) keys.insert(reference::voxel_key(points[i], d));

        const auto voxel = reference::reference_downsample(points, region, d, Downsample::voxel);
        ASSERT_EQ(voxel.points.size(), keys.size());
        auto key = keys.begin();
        for (const Point& centroid : voxel.points) {
            // The centroid lies in (or, by rounding, on the face of) its own voxel.
            for (int axis = 0; axis < 3; ++axis) {
                EXPECT_GE(double(centroid[axis]), double((*key)[axis]) * d - 1e-6);
                EXPECT_LE(double(centroid[axis]), double((*key)[axis] + 1) * d + 1e-6);
            }
            ++key;
        }

        const auto uniform = reference::reference_downsample(points, region, d, Downsample::uniform);
        ASSERT_EQ(uniform.indices.size(), keys.size());
        EXPECT_TRUE(std::is_sorted(uniform.indices.begin(), uniform.indices.end()));
        std::set<reference::VoxelKey> kept_keys;
        for (std::uint32_t kept : uniform.indices) {
            const reference::VoxelKey kept_key = reference::voxel_key(points[kept], d);
            kept_keys.insert(kept_key);
            const auto distance = [&](std::uint32_t i) {
                double sum = 0;
                for (int axis = 0; axis < 3; ++axis) {
                    const double delta = double(points[i][axis]) - (double(kept_key[axis]) + 0.5) * d;
                    sum += delta * delta;
                }
                return sum;
            };
            for (std::uint32_t i : region) {
                if (reference::voxel_key(points[i], d) == kept_key) {
                    EXPECT_LE(distance(kept), distance(i));
                }
            }
        }
        EXPECT_EQ(kept_keys, keys);
    }
}

}  // namespace
}  // namespace mfpc
