// The index-based foveation kernels against the reference Algorithm 1 (tests/support), on random
// clouds and structures with fixed seeds and on the shared real scene.
#include <algorithm>
#include <chrono>
#include <map>
#include <random>
#include <set>

#include <chrono>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/kernels/foveate.hpp"
#include "random_clouds.hpp"
#include "reference_foveation.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using reference::RawLabel;

std::vector<FoveatedStructure> random_structures(std::uint32_t seed, int count, int levels)
{
    std::mt19937 rng(seed);
    std::vector<FoveatedStructure> structures;
    for (int i = 0; i < count; ++i) structures.push_back(test::random_structure(rng, levels));
    return structures;
}

// Per-point labels from regions where each point appears at most once.
std::vector<RegionLabel> labels_from(const FoveationRegions& regions, std::size_t point_count)
{
    std::vector<RegionLabel> labels(point_count);
    for (int s = 0; s < regions.structures; ++s) {
        for (int k = 0; k <= regions.levels; ++k) {
            for (std::uint32_t point : regions.region(s, k)) {
                EXPECT_EQ(labels[point], RegionLabel{}) << "point " << point << " appears twice";
                labels[point] = {std::int16_t(s), std::int16_t(k)};
            }
        }
    }
    return labels;
}

std::vector<RawLabel> raw_from(const FoveationRegions& regions)
{
    std::vector<RawLabel> raw;
    for (int s = 0; s < regions.structures; ++s) {
        for (int k = 0; k <= regions.levels; ++k) {
            for (std::uint32_t point : regions.region(s, k)) raw.push_back({point, {std::int16_t(s), std::int16_t(k)}});
        }
    }
    return raw;
}

void sort_raw(std::vector<RawLabel>& raw)
{
    std::sort(raw.begin(), raw.end(), [](const RawLabel& a, const RawLabel& b) {
        return std::tie(a.label.structure, a.point, a.label.level) < std::tie(b.label.structure, b.point, b.label.level);
    });
}

struct Case {
    std::uint32_t seed;
    int structures;
    int levels;
    float index_voxel;
};

class FoveateAgainstReference : public ::testing::TestWithParam<Case> {};

TEST_P(FoveateAgainstReference, LabelsEqualReferencePointForPoint)
{
    const Case c = GetParam();
    const auto points = test::random_points(30000, c.seed);
    const auto structures = random_structures(c.seed * 31 + 1, c.structures, c.levels);
    const PointIndex index(points, {c.index_voxel});

    const FoveationRegions treated = foveation_regions(index, structures, FoveationMode::mfpc);
    EXPECT_EQ(labels_from(treated, points.size()), reference::reference_mfpc_labels(points, structures));

    const FoveationRegions raw = foveation_regions(index, structures, FoveationMode::raw);
    auto raw_labels = raw_from(raw);
    sort_raw(raw_labels);
    auto expected_raw = reference::reference_raw_labels(points, structures);
    sort_raw(expected_raw);
    EXPECT_EQ(raw_labels, expected_raw);

    std::size_t single_total = 0;
    for (int s = 0; s < c.structures; ++s) {
        const FoveationRegions single = foveation_regions(index, structures, FoveationMode::single, s);
        const auto levels = reference::reference_single_levels(points, structures[std::size_t(s)]);
        const auto labels = labels_from(single, points.size());
        for (std::size_t i = 0; i < points.size(); ++i) {
            ASSERT_EQ(labels[i].level, levels[i]) << "structure " << s << " point " << i;
            if (levels[i] >= 0) {
                ASSERT_EQ(labels[i].structure, s);
            }
        }
        single_total += single.members.size();
    }

    // The identities of the issue: |raw| = Σ |single_j|; redundant = |raw| - |mfpc|; mfpc ⊆ raw.
    EXPECT_EQ(raw.members.size(), single_total);
    EXPECT_EQ(treated.redundant_points(), raw.members.size() - treated.members.size());
    EXPECT_EQ(raw.redundant_points(), treated.redundant_points());
    const std::set<std::uint32_t> raw_points(raw.members.begin(), raw.members.end());
    for (std::uint32_t point : treated.members) EXPECT_TRUE(raw_points.count(point));
    EXPECT_EQ(raw_points.size(), treated.members.size());
}

TEST_P(FoveateAgainstReference, DownsamplingEqualsReferencePerRegion)
{
    const Case c = GetParam();
    const auto points = test::random_points(30000, c.seed + 100);
    const auto structures = random_structures(c.seed * 17 + 3, c.structures, c.levels);
    PointCloud cloud;
    cloud.points = points;
    cloud.width = std::uint32_t(points.size());
    std::mt19937 rng(c.seed + 200);
    for (std::size_t i = 0; i < points.size(); ++i) {
        cloud.colors.push_back({std::uint8_t(rng()), std::uint8_t(rng()), std::uint8_t(rng())});
    }
    // Odd seeds index the points alone, so colours are read point by point; even seeds index the
    // coloured cloud, so whole voxels bring their colour sums.
    const PointIndex index = c.seed % 2 ? PointIndex(cloud.points, {c.index_voxel}) : PointIndex(cloud, {c.index_voxel});
    ASSERT_EQ(index.sums_colors_of(cloud), c.seed % 2 == 0);
    const FoveationRegions regions = foveation_regions(index, structures, FoveationMode::mfpc);

    for (const Downsample mode : {Downsample::voxel, Downsample::uniform}) {
        const FoveatedCloud result = downsample_regions(cloud, regions, structures, mode);
        ASSERT_EQ(result.cloud.size(), result.labels.size());
        std::size_t begin = 0;
        for (const RegionSummary& summary : result.regions) {
            const auto members = regions.region(summary.structure, summary.level);
            const auto expected =
                reference::reference_downsample(points, members, summary.density, mode, cloud.colors);
            ASSERT_EQ(summary.points_after, expected.points.size())
                << to_string(mode) << " structure " << summary.structure << " level " << summary.level;
            std::vector<Point> got(result.cloud.points.begin() + std::ptrdiff_t(begin),
                                   result.cloud.points.begin() + std::ptrdiff_t(begin + summary.points_after));
            std::vector<std::uint32_t> got_sources(
                result.cloud.source_index.begin() + std::ptrdiff_t(begin),
                result.cloud.source_index.begin() + std::ptrdiff_t(begin + summary.points_after));
            for (std::size_t i = begin; i < begin + summary.points_after; ++i) {
                ASSERT_EQ(result.labels[i], (RegionLabel{std::int16_t(summary.structure), std::int16_t(summary.level)}));
            }
            if (mode == Downsample::voxel && summary.density > 0.0f) {
                // The reference lists centroids by voxel key; ours come in member order and name
                // their voxel by their lowest-index point. The double sums run in another order,
                // which could change the float centroid by an ulp; measured on these clouds they
                // are identical, and 1e-6 m is the allowance for that rounding.
                // Colour means are integer sums, the same in any order: equal exactly.
                struct Centroid {
                    reference::VoxelKey key;
                    Point point;
                    Rgb color;
                };
                std::vector<Centroid> ours;
                for (std::size_t i = 0; i < got.size(); ++i) {
                    ours.push_back({reference::voxel_key(points[got_sources[i]], summary.density), got[i],
                                    result.cloud.colors[begin + i]});
                }
                std::sort(ours.begin(), ours.end(), [](const auto& a, const auto& b) { return a.key < b.key; });
                for (std::size_t i = 0; i < ours.size(); ++i) {
                    EXPECT_LT((ours[i].point - expected.points[i]).cwiseAbs().maxCoeff(), 1e-6f)
                        << "voxel " << i << " of structure " << summary.structure << " level " << summary.level;
                    EXPECT_EQ(ours[i].color, expected.colors[i])
                        << "voxel " << i << " of structure " << summary.structure << " level " << summary.level;
                }
            } else {
                // Kept original points, with their colours: the same set (ours in voxel order, the
                // reference's ascending).
                for (std::size_t i = 0; i < got_sources.size(); ++i) {
                    EXPECT_EQ(result.cloud.colors[begin + i], cloud.colors[got_sources[i]]);
                }
                std::sort(got_sources.begin(), got_sources.end());
                EXPECT_EQ(got_sources, expected.indices);
            }
            begin += summary.points_after;
        }
        EXPECT_EQ(begin, result.cloud.size());
    }
}

INSTANTIATE_TEST_SUITE_P(RandomSeeds, FoveateAgainstReference,
                         ::testing::Values(Case{1, 1, 1, 0.01f}, Case{2, 2, 3, 0.01f}, Case{3, 3, 2, 0.05f},
                                           Case{4, 5, 3, 0.02f}, Case{5, 8, 4, 0.1f}, Case{6, 2, 3, 0.003f},
                                           Case{7, 16, 3, 0.03f}, Case{8, 4, 5, 0.01f}));

TEST(Foveate, LabelsDoNotDependOnIndexVoxelSize)
{
    const auto points = test::random_points(20000, 42);
    const auto structures = random_structures(43, 4, 3);
    FoveationRegions first;
    bool have_first = false;
    for (const float voxel : {0.004f, 0.01f, 0.05f, 0.5f}) {
        const PointIndex index(points, {voxel});
        const FoveationRegions regions = foveation_regions(index, structures, FoveationMode::mfpc);
        const auto labels = labels_from(regions, points.size());
        if (!have_first) {
            first = regions;
            have_first = true;
        }
        EXPECT_EQ(labels, labels_from(first, points.size())) << "index voxel " << voxel;
    }
}

TEST(Foveate, BitIdenticalAtAnyThreadCount)
{
    PointCloud cloud;
    cloud.points = test::random_points(60000, 9);
    cloud.width = std::uint32_t(cloud.size());
    // Coloured, so the index's colour sums and the colour means are covered too.
    for (std::size_t i = 0; i < cloud.size(); ++i)
        cloud.colors.push_back({std::uint8_t(i * 7), std::uint8_t(i * 13), std::uint8_t(i * 31)});
    FoveationConfig config;
    config.structures = random_structures(10, 6, 3);
    const PointIndex index(cloud, {0.02f});

    std::vector<FoveatedCloud> results;
    for (const std::size_t threads : {1u, 2u, 4u}) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        for (const Downsample mode : {Downsample::voxel, Downsample::uniform}) {
            config.downsample = mode;
            results.push_back(foveate(cloud, index, config, FoveationMode::mfpc));
            results.push_back(foveate(cloud, index, config, FoveationMode::raw));
        }
    }
    for (std::size_t i = 4; i < results.size(); ++i) {
        const FoveatedCloud& a = results[i % 4];
        const FoveatedCloud& b = results[i];
        EXPECT_EQ(a.cloud.points, b.cloud.points) << "result " << i;
        EXPECT_EQ(a.cloud.source_index, b.cloud.source_index) << "result " << i;
        EXPECT_EQ(a.cloud.colors, b.cloud.colors) << "result " << i;
        EXPECT_EQ(a.labels, b.labels) << "result " << i;
    }
}

void expect_same_foveation(const FoveatedCloud& a, const FoveatedCloud& b, const std::string& what)
{
    EXPECT_EQ(a.cloud.points, b.cloud.points) << what;
    EXPECT_EQ(a.cloud.source_index, b.cloud.source_index) << what;
    EXPECT_EQ(a.cloud.colors, b.cloud.colors) << what;
    EXPECT_EQ(a.cloud.normals, b.cloud.normals) << what;
    EXPECT_EQ(a.labels, b.labels) << what;
    EXPECT_EQ(a.points_before_downsampling, b.points_before_downsampling) << what;
    EXPECT_EQ(a.redundant_points, b.redundant_points) << what;
    ASSERT_EQ(a.regions.size(), b.regions.size()) << what;
    for (std::size_t r = 0; r < a.regions.size(); ++r) {
        EXPECT_EQ(a.regions[r].points_before, b.regions[r].points_before) << what << " region " << r;
        EXPECT_EQ(a.regions[r].points_after, b.regions[r].points_after) << what << " region " << r;
    }
}

// Random points with colours and random unit normals.
PointCloud random_cloud_with_attributes(std::size_t count, std::uint32_t seed)
{
    PointCloud cloud;
    cloud.points = test::random_points(count, seed);
    cloud.width = std::uint32_t(cloud.size());
    std::mt19937 rng(seed + 1);
    std::normal_distribution<float> gauss;
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        cloud.colors.push_back({std::uint8_t(i * 7), std::uint8_t(i * 13), std::uint8_t(i * 31)});
        cloud.normals.push_back(Point(gauss(rng), gauss(rng), gauss(rng)).normalized());
    }
    return cloud;
}

// Indexing only the points some outer box covers changes nothing in the result, for every mode
// and downsampling, on coloured clouds with normals whose structures cover parts of the cloud.
TEST(Foveate, OneShotEqualsFoveationOverAWholeIndex)
{
    const PointCloud cloud = random_cloud_with_attributes(40000, 21);
    for (const std::uint32_t seed : {23u, 24u, 25u}) {
        FoveationConfig config;
        config.structures = random_structures(seed, int(seed % 4) + 1, 3);
        const PointIndex index(cloud);  // default voxel, as the one-shot index
        for (const Downsample downsample : {Downsample::voxel, Downsample::uniform}) {
            config.downsample = downsample;
            for (const FoveationMode mode : {FoveationMode::mfpc, FoveationMode::raw, FoveationMode::single}) {
                const std::string what = "seed " + std::to_string(seed) + " " + to_string(mode) + " " +
                                         to_string(downsample);
                expect_same_foveation(foveate(cloud, config, mode), foveate(cloud, index, config, mode), what);
            }
        }
    }
    FoveationConfig config;
    config.structures = random_structures(26, 2, 3);
    EXPECT_THROW(foveate(cloud, config, FoveationMode::single, 2), Error);
    config.structures[1].levels = 2;
    EXPECT_THROW(foveate(cloud, config, FoveationMode::mfpc), Error);
    config.structures[1].levels = 3;
    PointCloud short_colours = cloud;
    short_colours.colors.resize(10);
    EXPECT_THROW(foveate(short_colours, config, FoveationMode::mfpc), Error);
    expect_same_foveation(foveate(cloud, config, FoveationMode::none), foveate(cloud, PointIndex(cloud), config, FoveationMode::none), "none");
}

// The one-shot foveate lists no index: it tells downsampling where an index would list each point.
// The same result as over an index of the whole cloud where that order shows: a fovea that keeps
// every point (its points come out in index order), densities that are no multiple of the index
// voxel, and a structure reaching a thousand kilometres out that keeps every point (too many leaves
// to key: the covered points are then indexed).
TEST(Foveate, OneShotFollowsTheIndexOrderWithoutAnIndex)
{
    const PointCloud cloud = random_cloud_with_attributes(30000, 71);
    const PointIndex index(cloud);
    FoveationConfig config;
    config.structures = random_structures(72, 2, 3);
    config.structures[0].density_fovea = 0.0f;
    config.structures[1].density_outer = 0.013f;
    config.structures[1].density_fovea = 0.0037f;
    FoveationConfig far = config;
    far.structures[1].outer_min = Eigen::Vector3f::Constant(-1e6f);
    far.structures[1].outer_size = Eigen::Vector3f::Constant(2e6f);
    far.structures[1].fovea_size = Eigen::Vector3f::Constant(0.5f);
    far.structures[1].fovea_offset = Eigen::Vector3f::Zero();
    // Every point kept: downsampling voxels would be too many on such a box.
    far.structures[1].density_outer = 0.0f;
    far.structures[1].density_fovea = 0.0f;
    for (const FoveationConfig* c : {&config, &far})
        for (const Downsample downsample : {Downsample::voxel, Downsample::uniform})
            for (const FoveationMode mode : {FoveationMode::mfpc, FoveationMode::raw, FoveationMode::single}) {
                FoveationConfig run = *c;
                run.downsample = downsample;
                const std::string what = std::string(c == &far ? "far " : "") + to_string(mode) + " " + to_string(downsample);
                const FoveatedCloud one_shot = foveate(cloud, run, mode);
                expect_same_foveation(one_shot, foveate(cloud, index, run, mode), what);
                EXPECT_GT(one_shot.cloud.size(), 0u) << what;
            }
}

// Stray points a thousand kilometres out on every axis (too far apart for the index to number its
// leaves in 64 bits) change nothing: over an index of the whole cloud, strays included, the result
// is the one without them.
TEST(Foveate, StraysFarOutOnEveryAxisChangeNothing)
{
    const PointCloud cloud = random_cloud_with_attributes(20000, 27);
    PointCloud strayed = cloud;
    for (const Point& stray : {Point(-1e6f, -1e6f, -1e6f), Point(1e6f, 1e6f, 1e6f), Point(1e6f, -1e6f, 0.5f)}) {
        strayed.points.push_back(stray);
        strayed.colors.push_back({1, 2, 3});
        strayed.normals.push_back(Point::UnitZ());
    }
    strayed.width = std::uint32_t(strayed.size());
    // Points come out in index order, which follows the index voxel: both indexes use one.
    const PointIndex index(cloud, {0.01f});
    const PointIndex strayed_index(strayed, {0.01f});
    FoveationConfig config;
    config.structures = random_structures(28, 2, 3);
    for (const FoveationMode mode : {FoveationMode::mfpc, FoveationMode::raw})
        expect_same_foveation(foveate(cloud, index, config, mode), foveate(strayed, strayed_index, config, mode),
                              to_string(mode));
}

// foveate() reads the members through the runs and never lists them; its result is that of
// downsampling the listed regions, in every mode, for both downsamplings, with a structure that
// keeps every point (d_k = 0), on a cloud with colours and normals.
TEST(Foveate, FoveateEqualsDownsamplingTheListedRegions)
{
    const PointCloud cloud = random_cloud_with_attributes(30000, 61);
    FoveationConfig config;
    config.structures = random_structures(63, 3, 3);
    config.structures[2].density_outer = config.structures[2].density_fovea = 0.0f;
    const PointIndex index(cloud, {0.02f});
    for (const Downsample downsample : {Downsample::voxel, Downsample::uniform}) {
        config.downsample = downsample;
        for (const FoveationMode mode : {FoveationMode::mfpc, FoveationMode::raw, FoveationMode::single}) {
            const int single = mode == FoveationMode::single ? 2 : 0;
            const FoveationRegions regions = foveation_regions(index, config.structures, mode, single);
            const auto called = std::chrono::steady_clock::now();
            const FoveatedCloud fused = foveate(cloud, index, config, mode, single);
            const double call_ms =
                std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - called).count();
            const std::string what = std::string(to_string(mode)) + " " + to_string(downsample);
            expect_same_foveation(fused, downsample_regions(cloud, regions, config.structures, downsample), what);
            EXPECT_EQ(fused.points_before_downsampling, regions.members.size()) << what;
            EXPECT_GT(fused.cloud.size(), 0u) << what;
            // The two phases are timed inside the call: each took some time, and together no
            // more than the whole call.
            EXPECT_GT(fused.label_ms, 0.0) << what;
            EXPECT_GT(fused.downsample_ms, 0.0) << what;
            EXPECT_LE(fused.label_ms + fused.downsample_ms, call_ms) << what;
        }
    }
}

// Hand-made regions that downsampling would read out of bounds are errors: offsets that do not
// partition the members or the runs, and runs that do not fit their index.
TEST(Foveate, MalformedRegionsAreErrors)
{
    PointCloud cloud;
    cloud.points = test::random_points(20000, 71);
    cloud.width = std::uint32_t(cloud.size());
    const auto structures = random_structures(72, 2, 3);
    const PointIndex index(cloud.points, {0.05f});
    const FoveationRegions regions = foveation_regions(index, structures, FoveationMode::mfpc);
    ASSERT_FALSE(regions.runs.empty());
    EXPECT_NO_THROW(downsample_regions(cloud, regions, structures, Downsample::voxel));

    auto expect_error = [&](const FoveationRegions& wrong, const std::string& what) {
        EXPECT_THROW(downsample_regions(cloud, wrong, structures, Downsample::voxel), Error) << what;
    };
    FoveationRegions wrong = regions;
    wrong.offsets.pop_back();
    expect_error(wrong, "offsets one short");
    wrong = regions;
    wrong.offsets.back() += 1;
    expect_error(wrong, "offsets past the members");
    wrong = regions;
    std::swap(wrong.offsets[1], wrong.offsets[wrong.offsets.size() - 2]);
    if (wrong.offsets[1] != regions.offsets[1]) expect_error(wrong, "offsets not ascending");
    wrong = regions;
    wrong.levels = 2;
    expect_error(wrong, "levels other than the structures'");
    wrong = regions;
    wrong.run_offsets.back() += 1;
    expect_error(wrong, "run offsets past the runs");
    wrong = regions;
    wrong.run_offsets.resize(3);
    expect_error(wrong, "run offsets one per region");

    const std::uint32_t voxels = std::uint32_t(index.voxels().size());
    const std::uint32_t points = std::uint32_t(cloud.size());
    for (const RegionRun& bad : {RegionRun{0, points + 5, 3, 3}, RegionRun{7, 3, 3, 3},
                                 RegionRun{0, 1, voxels - 1, voxels + 1},
                                 RegionRun{0, index.voxels()[0].end + 1, 0, 1}}) {
        wrong = regions;
        wrong.runs[0] = bad;
        expect_error(wrong, "run " + std::to_string(bad.begin) + ".." + std::to_string(bad.end) + " voxels " +
                                std::to_string(bad.voxel_begin) + ".." + std::to_string(bad.voxel_end));
    }
}

// Downsampling takes the points of a run tested one by one with one voxel lookup when the index
// voxel the run names falls in one downsampling voxel. Runs that name a voxel not holding them
// (regions edited by hand) are taken point by point instead: the same sums in the same order.
TEST(Foveate, PointRunsNamingAnotherVoxelAreTakenPointByPoint)
{
    PointCloud cloud;
    cloud.points = test::random_points(30000, 31);
    cloud.width = std::uint32_t(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        cloud.colors.push_back({std::uint8_t(i * 5), std::uint8_t(i * 11), std::uint8_t(i * 29)});
        cloud.normals.push_back(Point(float(i % 7) - 3.0f, 1.0f, float(i % 5)).normalized());
    }
    // Index voxels of several points, so some straddle a face and their points come as point
    // runs; densities that are multiples of them, so such a run can fall in one voxel.
    auto structures = random_structures(32, 3, 3);
    for (FoveatedStructure& structure : structures) {
        structure.density_outer = 0.4f;
        structure.density_fovea = 0.2f;
    }
    const PointIndex index(cloud, {0.1f});
    const FoveationRegions regions = foveation_regions(index, structures, FoveationMode::mfpc);
    for (const std::uint32_t wrong : {0u, std::uint32_t(index.voxels().size()), ~0u}) {
        FoveationRegions edited = regions;
        std::size_t point_runs = 0;
        for (RegionRun& run : edited.runs) {
            if (run.whole_voxels()) continue;
            run.voxel_begin = run.voxel_end = wrong;
            ++point_runs;
        }
        ASSERT_GT(point_runs, 0u);
        for (const Downsample mode : {Downsample::voxel, Downsample::uniform}) {
            expect_same_foveation(downsample_regions(cloud, edited, structures, mode),
                                  downsample_regions(cloud, regions, structures, mode),
                                  "voxel " + std::to_string(wrong) + " " + to_string(mode));
        }
    }

    // An empty point run adds nothing (not an empty voxel), even naming a voxel of its region:
    // a region whose only run is such gets no point.
    const int levels = regions.levels + 1;
    int target = -1;
    for (int r = 0; r < regions.region_count() && target < 0; ++r)
        if (regions.run_offsets[std::size_t(r) + 1] > regions.run_offsets[std::size_t(r)]) target = r;
    ASSERT_GE(target, 0);
    FoveationRegions with_empty = regions;
    const std::uint32_t named = regions.runs[regions.run_offsets[std::size_t(target)]].voxel_begin;
    const std::uint32_t at = index.voxels()[named].begin;
    const auto first = with_empty.runs.begin() + with_empty.run_offsets[std::size_t(target)];
    const auto last = with_empty.runs.begin() + with_empty.run_offsets[std::size_t(target) + 1];
    const std::uint32_t removed = std::uint32_t(last - first) - 1;
    *first = RegionRun{at, at, named, named};
    with_empty.runs.erase(first + 1, last);
    for (std::size_t r = std::size_t(target) + 1; r < with_empty.run_offsets.size(); ++r) with_empty.run_offsets[r] -= removed;
    const FoveatedCloud emptied = downsample_regions(cloud, with_empty, structures, Downsample::voxel);
    EXPECT_EQ(emptied.regions[std::size_t(target)].points_after, 0u);
    for (const Point& p : emptied.cloud.points) ASSERT_TRUE(p.allFinite());

    // A point run handed to a region whose box's voxels do not hold its points (the box grown by
    // a voxel on every side does not) is still an error.
    bool moved = false;
    for (int from = 0; from < regions.region_count() && !moved; ++from) {
        for (std::uint32_t i = regions.run_offsets[std::size_t(from)]; i < regions.run_offsets[std::size_t(from) + 1] && !moved; ++i) {
            const RegionRun& run = regions.runs[i];
            if (run.whole_voxels()) continue;
            for (int to = 0; to < regions.region_count() && !moved; ++to) {
                const FoveatedStructure& structure = structures[std::size_t(to / levels)];
                Box box = structure.level_box(to % levels);
                box.min.array() -= structure.density(to % levels);
                box.max.array() += structure.density(to % levels);
                if (regions.region(to / levels, to % levels).empty() || box.contains(index.ordered_points()[run.begin])) continue;
                FoveationRegions wrong = regions;
                wrong.runs.insert(wrong.runs.begin() + wrong.run_offsets[std::size_t(to)], run);
                for (std::size_t r = std::size_t(to) + 1; r < wrong.run_offsets.size(); ++r) ++wrong.run_offsets[r];
                EXPECT_THROW(downsample_regions(cloud, wrong, structures, Downsample::voxel), Error);
                moved = true;
            }
        }
    }
    EXPECT_TRUE(moved);
}

TEST(Foveate, PointsExactlyOnBoxFaces)
{
    FoveatedStructure s;
    s.levels = 2;
    s.outer_min = {0.0f, 0.0f, 0.0f};
    s.outer_size = {1.0f, 1.0f, 1.0f};
    s.fovea_size = {0.2f, 0.2f, 0.2f};
    s.fovea_offset = {0.1f, -0.2f, 0.0f};
    std::vector<Point> points;
    // Every corner and face centre of every level box, and points a float step outside each face.
    for (int k = 0; k <= s.levels; ++k) {
        const Box box = s.level_box(k);
        for (int corner = 0; corner < 8; ++corner) {
            const Point p((corner & 1) ? box.max.x() : box.min.x(), (corner & 2) ? box.max.y() : box.min.y(),
                          (corner & 4) ? box.max.z() : box.min.z());
            points.push_back(p);
            for (int axis = 0; axis < 3; ++axis) {
                Point out = p;
                const bool at_max = axis == 0 ? (corner & 1) : axis == 1 ? (corner & 2) : (corner & 4);
                out[axis] = std::nextafter(p[axis], at_max ? 2.0f : -2.0f);
                points.push_back(out);
                Point in = p;
                in[axis] = std::nextafter(p[axis], at_max ? -2.0f : 2.0f);
                points.push_back(in);
            }
        }
    }
    const std::vector<FoveatedStructure> structures{s};
    const auto expected = reference::reference_single_levels(points, s);
    for (const float voxel : {0.01f, 0.1f, 1.0f}) {
        const PointIndex index(points, {voxel});
        const auto labels = labels_from(foveation_regions(index, structures, FoveationMode::mfpc), points.size());
        for (std::size_t i = 0; i < points.size(); ++i) {
            EXPECT_EQ(labels[i].level, expected[i]) << "point " << i << " index voxel " << voxel;
        }
    }
    // A corner of the fovea box is in the fovea (closed boxes).
    EXPECT_EQ(s.level_of(s.level_box(2).max), 2);
}

// Where a denser structure covers a face of a coarser one, the face cannot change any point's
// region (redundancy treatment keeps the denser level on both sides of it): the labels still equal
// the reference, and the points there come as whole index voxels, none tested one by one.
TEST(Foveate, FacesUnderADenserFoveaAreNotTestedPointByPoint)
{
    FoveatedStructure coarse;  // level 2 box from x = 0.2667: that face crosses the dense fovea
    coarse.outer_min = {0.0f, 0.0f, 0.0f};
    coarse.outer_size = {1.0f, 1.0f, 1.0f};
    coarse.fovea_size = {0.2f, 0.2f, 0.2f};
    FoveatedStructure dense;  // fovea [0.25, 0.30] x [0.47, 0.53] x [0.49, 0.51], d_m = 2 mm
    dense.outer_min = {0.2f, 0.42f, 0.44f};
    dense.outer_size = {0.15f, 0.16f, 0.12f};
    dense.fovea_size = {0.05f, 0.06f, 0.02f};
    dense.fovea_offset = {0.0f, 0.0f, 0.0f};  // centred in its outer box
    dense.density_outer = 0.01f;
    dense.density_fovea = 0.002f;
    ASSERT_LT(dense.level_box(3).min.x(), coarse.level_box(2).min.x());
    ASSERT_GT(dense.level_box(3).max.x(), coarse.level_box(2).min.x());
    // A plane of points on a 1 mm grid, half a millimetre off the 5 mm index voxels' faces (and so
    // off the dense fovea's faces, which lie on them).
    std::vector<Point> points;
    for (int i = 0; i < 150; ++i) {
        for (int j = 0; j < 100; ++j) {
            points.emplace_back(0.2005f + 0.001f * float(i), 0.4505f + 0.001f * float(j), 0.5005f);
        }
    }
    const std::vector<FoveatedStructure> structures{coarse, dense};
    const PointIndex index(points, {0.005f});

    const FoveationRegions treated = foveation_regions(index, structures, FoveationMode::mfpc);
    EXPECT_EQ(labels_from(treated, points.size()), reference::reference_mfpc_labels(points, structures));
    const FoveationRegions raw = foveation_regions(index, structures, FoveationMode::raw);
    EXPECT_EQ(treated.redundant_points(), raw.members.size() - treated.members.size());

    const int fovea = treated.region_id(1, 3);
    ASSERT_GT(treated.offsets[std::size_t(fovea) + 1], treated.offsets[std::size_t(fovea)]);
    const std::uint32_t first_run = treated.run_offsets[std::size_t(fovea)];
    for (std::uint32_t r = first_run; r < treated.run_offsets[std::size_t(fovea) + 1]; ++r) {
        EXPECT_TRUE(treated.runs[r].whole_voxels()) << "run " << r << " of the dense fovea is taken point by point";
    }
}

TEST(Foveate, ModeNonePassesTheCloudThrough)
{
    PointCloud cloud;
    cloud.points = test::random_points(100, 3);
    cloud.width = 100;
    FoveationConfig config;
    config.structures = random_structures(4, 2, 3);
    const PointIndex index(cloud.points);
    const FoveatedCloud result = foveate(cloud, index, config, FoveationMode::none);
    EXPECT_EQ(result.cloud.points, cloud.points);
    EXPECT_EQ(result.labels.size(), cloud.size());
    EXPECT_THROW(foveation_regions(index, config.structures, FoveationMode::none), Error);
}

TEST(Foveate, RejectsContradictoryInput)
{
    PointCloud cloud;
    cloud.points = test::random_points(100, 3);
    const PointIndex index(cloud.points);
    auto structures = random_structures(5, 2, 3);
    structures[1].levels = 2;
    EXPECT_THROW(foveation_regions(index, structures, FoveationMode::mfpc), Error);
    structures[1].levels = 3;
    EXPECT_THROW(foveation_regions(index, structures, FoveationMode::single, 2), Error);
    auto deep = structures;
    for (auto& s : deep) s.levels = 127;
    EXPECT_THROW(foveation_regions(index, deep, FoveationMode::mfpc), Error);
    EXPECT_THROW(foveation_regions(index, std::span<const FoveatedStructure>(), FoveationMode::mfpc), Error);

    PointCloud other = cloud;
    FoveationConfig config;
    config.structures = random_structures(5, 2, 3);
    EXPECT_THROW(foveate(other, index, config, FoveationMode::mfpc), Error);  // index of another cloud
    const FoveationRegions regions = foveation_regions(index, config.structures, FoveationMode::mfpc);
    EXPECT_THROW(downsample_regions(other, regions, config.structures, Downsample::voxel), Error);
    FoveationRegions hand_made;
    hand_made.structures = 2;
    hand_made.levels = 3;
    hand_made.offsets.assign(9, 1);
    hand_made.offsets[0] = 0;
    hand_made.members = {1000};
    EXPECT_THROW(downsample_regions(cloud, hand_made, config.structures, Downsample::voxel), Error);
}

TEST(Foveate, EmptyCloudGivesEmptyRegions)
{
    const PointCloud cloud;
    const PointIndex index(cloud.points);
    FoveationConfig config;
    config.structures = random_structures(6, 2, 3);
    const FoveatedCloud result = foveate(cloud, index, config, FoveationMode::mfpc);
    EXPECT_TRUE(result.cloud.empty());
    EXPECT_EQ(result.regions.size(), 8u);
}

// The shared real scene with the shipped two-carton config: the same identities, and the kernel
// equals the reference point for point.
TEST(Foveate, RealSceneMatchesReference)
{
    MFPC_SHARED_FILE_OR_SKIP(scene_path, "milk_cartoon_all_small_clorox.pcd");
    const auto config_path = std::filesystem::path(MFPC_SOURCE_DIR) / "examples/configs/milk_pair_two.json";
    if (!std::filesystem::exists(config_path)) GTEST_SKIP() << config_path << " is absent";
    const PointCloud cloud = read_cloud(scene_path);
    const FoveationConfig config = read_foveation_config(config_path);
    const PointIndex index(cloud.points);

    const FoveationRegions treated = foveation_regions(index, config.structures, FoveationMode::mfpc);
    const FoveationRegions raw = foveation_regions(index, config.structures, FoveationMode::raw);
    EXPECT_EQ(labels_from(treated, cloud.size()), reference::reference_mfpc_labels(cloud.points, config.structures));
    EXPECT_GT(treated.members.size(), 1000u);
    std::size_t single_total = 0;
    for (int s = 0; s < int(config.structures.size()); ++s) {
        single_total += foveation_regions(index, config.structures, FoveationMode::single, s).members.size();
    }
    EXPECT_EQ(raw.members.size(), single_total);
    EXPECT_EQ(treated.redundant_points(), raw.members.size() - treated.members.size());

    const FoveatedCloud result = downsample_regions(cloud, treated, config.structures, config.downsample);
    EXPECT_LT(result.cloud.size(), treated.members.size());
    expect_same_foveation(foveate(cloud, config, FoveationMode::mfpc), result, "one-shot");
    // Every kept point's source position is a pixel of the 640x480 scan.
    for (std::uint32_t source : result.cloud.source_index) EXPECT_LT(source, 640u * 480u);

    // Runs are whole voxels (contiguous, their points exactly) or points tested one by one within
    // the voxel they name, and together they are the members.
    const auto voxels = index.voxels();
    const auto order = index.point_order();
    std::size_t whole = 0;
    for (int r = 0; r < treated.region_count(); ++r) {
        std::vector<std::uint32_t> from_runs;
        for (std::uint32_t i = treated.run_offsets[std::size_t(r)]; i < treated.run_offsets[std::size_t(r) + 1]; ++i) {
            const RegionRun& run = treated.runs[i];
            if (run.whole_voxels()) {
                ++whole;
                EXPECT_EQ(run.begin, voxels[run.voxel_begin].begin);
                EXPECT_EQ(run.end, voxels[run.voxel_end - 1].end);
            } else {
                ASSERT_EQ(run.voxel_begin, run.voxel_end);
                ASSERT_LT(run.voxel_begin, voxels.size());
                EXPECT_LE(voxels[run.voxel_begin].begin, run.begin);
                EXPECT_LE(run.end, voxels[run.voxel_begin].end);
                EXPECT_LT(run.begin, run.end);
            }
            from_runs.insert(from_runs.end(), order.begin() + run.begin, order.begin() + run.end);
        }
        const auto members = treated.region(r / (treated.levels + 1), r % (treated.levels + 1));
        EXPECT_EQ(from_runs, std::vector<std::uint32_t>(members.begin(), members.end())) << "region " << r;
    }
    EXPECT_GT(whole, 0u);
}

// An index built from a coloured cloud keeps colour sums per voxel, and downsampling with them
// gives the colours that reading every point's colour gives.
TEST(Foveate, VoxelColourSumsGiveTheSameColours)
{
    MFPC_SHARED_FILE_OR_SKIP(scene_path, "milk_cartoon_all_small_clorox.pcd");
    const auto config_path = std::filesystem::path(MFPC_SOURCE_DIR) / "examples/configs/milk_pair_two.json";
    if (!std::filesystem::exists(config_path)) GTEST_SKIP() << config_path << " is absent";
    const PointCloud cloud = read_cloud(scene_path);
    ASSERT_TRUE(cloud.has_colors());
    const FoveationConfig config = read_foveation_config(config_path);
    const PointIndex with_sums(cloud);
    const PointIndex without_sums(cloud.points);
    ASSERT_EQ(with_sums.voxel_color_sums().size(), with_sums.voxels().size());
    EXPECT_TRUE(without_sums.voxel_color_sums().empty());

    const FoveatedCloud a = foveate(cloud, with_sums, config, FoveationMode::mfpc);
    const FoveatedCloud b = foveate(cloud, without_sums, config, FoveationMode::mfpc);
    EXPECT_EQ(a.cloud.points, b.cloud.points);
    EXPECT_EQ(a.cloud.colors, b.cloud.colors);
    EXPECT_EQ(a.cloud.source_index, b.cloud.source_index);
    EXPECT_EQ(a.cloud.colors.size(), a.cloud.size());
}

TEST(Foveate, ColourMeansAreRoundedIntegerMeans)
{
    // One structure, no foveation to speak of: level 0 covers everything and its voxel (1 m) holds
    // all four points, whole index voxels and single points alike.
    PointCloud cloud;
    cloud.points = {{0.1f, 0.1f, 0.1f}, {0.2f, 0.1f, 0.1f}, {0.1f, 0.3f, 0.1f}, {0.4f, 0.4f, 0.4f}};
    cloud.width = 4;
    cloud.colors = {{255, 0, 10}, {254, 1, 11}, {0, 2, 11}, {1, 2, 11}};
    FoveationConfig config;
    FoveatedStructure s;
    s.levels = 1;
    s.outer_min = {0.0f, 0.0f, 0.0f};
    s.outer_size = {0.5f, 0.5f, 0.5f};
    s.fovea_size = {0.01f, 0.01f, 0.01f};
    s.density_outer = 1.0f;
    s.density_fovea = 1.0f;
    config.structures = {s};
    for (const float cell : {0.05f, 1.0f}) {
        const PointIndex index(cloud, {cell});
        const FoveatedCloud out = foveate(cloud, index, config, FoveationMode::mfpc);
        ASSERT_EQ(out.cloud.size(), 1u);
        // r: 510 / 4 = 127.5 rounds up; g: 5 / 4 = 1.25 rounds down; b: 43 / 4 = 10.75 rounds up.
        EXPECT_EQ(out.cloud.colors[0].r, 128);
        EXPECT_EQ(out.cloud.colors[0].g, 1);
        EXPECT_EQ(out.cloud.colors[0].b, 11);
    }
}

TEST(PointIndexColours, MismatchedColoursAreAnError)
{
    PointCloud cloud;
    cloud.points = test::random_points(100, 3);
    cloud.colors.resize(99);
    EXPECT_THROW(PointIndex{cloud}, Error);
}

}  // namespace
}  // namespace mfpc
