// Foveation of a small fuzzed cloud under a fuzzed config, against the reference Algorithm 1 of
// tests/support/reference_foveation.hpp (loops over every point, no index):
//  - labelling (mfpc and raw modes): the same label for every point, no point twice in mfpc mode;
//  - downsampling (voxel and uniform): per region, the same number of points, the same kept
//    original points, centroids within 1e-6 m of the reference's (the double sums run in another
//    order; 1e-6 is the allowance tests/kernels/test_foveate.cpp measured);
//  - the one-shot foveate (which indexes only the covered points) keeps what the regions give.
// Coordinates lie on a 1/32 m grid (boxes too), so points sit on faces and on each other; at most
// 256 points and 3 structures keep a run short.
#include <algorithm>
#include <set>
#include <tuple>
#include <vector>

#include "fuzz_support.hpp"
#include "mfpc/kernels/foveate.hpp"
#include "reference_foveation.hpp"

namespace {

using namespace mfpc;

std::vector<RegionLabel> labels_from(const FoveationRegions& regions, std::size_t point_count)
{
    std::vector<RegionLabel> labels(point_count);
    for (int s = 0; s < regions.structures; ++s) {
        for (int k = 0; k <= regions.levels; ++k) {
            for (std::uint32_t point : regions.region(s, k)) {
                fuzz::check(point < point_count, "a region member beyond the cloud");
                fuzz::check(labels[point] == RegionLabel{}, "mfpc labelling holds a point twice");
                labels[point] = {std::int16_t(s), std::int16_t(k)};
            }
        }
    }
    return labels;
}

std::vector<reference::RawLabel> raw_from(const FoveationRegions& regions)
{
    std::vector<reference::RawLabel> raw;
    for (int s = 0; s < regions.structures; ++s) {
        for (int k = 0; k <= regions.levels; ++k) {
            for (std::uint32_t point : regions.region(s, k)) raw.push_back({point, {std::int16_t(s), std::int16_t(k)}});
        }
    }
    std::sort(raw.begin(), raw.end(), [](const auto& a, const auto& b) {
        return std::tie(a.label.structure, a.point, a.label.level) < std::tie(b.label.structure, b.point, b.label.level);
    });
    return raw;
}

void check_downsampling(const PointCloud& cloud, const FoveationRegions& regions,
                        const std::vector<FoveatedStructure>& structures, Downsample mode)
{
    const FoveatedCloud result = downsample_regions(cloud, regions, structures, mode);
    fuzz::check(result.cloud.size() == result.labels.size(), "labels and kept points differ in number");
    fuzz::check(result.cloud.source_index.size() == result.cloud.size(), "kept points without source positions");
    std::size_t begin = 0;
    for (const RegionSummary& summary : result.regions) {
        const auto members = regions.region(summary.structure, summary.level);
        reference::Downsampled expected;
        try {
            expected = reference::reference_downsample(cloud.points, members, summary.density, mode, cloud.colors);
        } catch (const Error& error) {
            fuzz::fail(std::string("the reference refuses the kernel's region: ") + error.what());
        }
        fuzz::check(summary.points_after == expected.points.size(), "a region keeps another number of points");
        fuzz::check(begin + summary.points_after <= result.cloud.size(), "region summaries beyond the kept points");
        for (std::size_t i = begin; i < begin + summary.points_after; ++i) {
            fuzz::check(result.labels[i] == RegionLabel{std::int16_t(summary.structure), std::int16_t(summary.level)},
                        "a kept point carries another region's label");
        }
        if (mode == Downsample::voxel && summary.density > 0) {
            struct Centroid {
                reference::VoxelKey key;
                Point point;
            };
            std::vector<Centroid> ours;
            for (std::size_t i = begin; i < begin + summary.points_after; ++i) {
                ours.push_back({reference::voxel_key(cloud.points[result.cloud.source_index[i]], summary.density),
                                result.cloud.points[i]});
            }
            std::sort(ours.begin(), ours.end(), [](const auto& a, const auto& b) { return a.key < b.key; });
            for (std::size_t i = 0; i < ours.size(); ++i) {
                fuzz::check((ours[i].point - expected.points[i]).cwiseAbs().maxCoeff() < 1e-6f,
                            "a centroid differs from the reference's");
            }
        } else {
            std::vector<std::uint32_t> sources(result.cloud.source_index.begin() + std::ptrdiff_t(begin),
                                               result.cloud.source_index.begin() +
                                                   std::ptrdiff_t(begin + summary.points_after));
            std::sort(sources.begin(), sources.end());
            fuzz::check(sources == expected.indices, "a region keeps other points than the reference");
        }
        begin += summary.points_after;
    }
    fuzz::check(begin == result.cloud.size(), "region summaries do not cover the kept points");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    fuzz::Bytes bytes(data, size);
    FoveationConfig config;
    config.downsample = bytes.byte() % 2 ? Downsample::uniform : Downsample::voxel;
    const int levels = bytes.in(1, 4);
    const int structure_count = bytes.in(1, 3);
    for (int s = 0; s < structure_count; ++s) {
        FoveatedStructure structure;
        structure.levels = levels;
        for (int axis = 0; axis < 3; ++axis) {
            structure.outer_min[axis] = bytes.grid(-1, 0.5f, 48);
            structure.outer_size[axis] = bytes.grid(1.0f / 32, 1.5f, 47);
            structure.fovea_size[axis] = structure.outer_size[axis] * bytes.grid(0.125f, 1, 7);
            structure.fovea_offset[axis] = bytes.grid(-0.75f, 0.75f, 48);
        }
        structure.density_outer = bytes.grid(0, 0.25f, 8);
        structure.density_fovea = bytes.grid(0, 0.25f, 8);
        structure.keypoint_radius_outer = bytes.grid(0.01f, 0.05f, 4);
        structure.keypoint_radius_fovea = bytes.grid(0.01f, 0.05f, 4);
        config.structures.push_back(structure);
    }
    const float index_voxel = bytes.grid(0.01f, 0.5f, 49);
    const bool colored = bytes.byte() % 2;
    PointCloud cloud;
    while (bytes.left() >= 6 && cloud.size() < 256) {
        cloud.points.emplace_back(bytes.grid(-1.25f, 1.25f, 80), bytes.grid(-1.25f, 1.25f, 80),
                                  bytes.grid(-1.25f, 1.25f, 80));
    }
    if (cloud.empty()) return 0;
    cloud.width = std::uint32_t(cloud.size());
    if (colored) {
        for (std::size_t i = 0; i < cloud.size(); ++i) {
            cloud.colors.push_back({std::uint8_t(i * 37), std::uint8_t(i * 91), std::uint8_t(i * 13)});
        }
    }

    // A structure the library refuses (a fovea past its outer box's limit) is a refused input for
    // the reference too: leave those.
    try {
        for (const FoveatedStructure& structure : config.structures) structure.level_box(0);
    } catch (const Error&) {
        return 0;
    }
    std::vector<RegionLabel> expected_labels;
    std::vector<reference::RawLabel> expected_raw;
    try {
        expected_labels = reference::reference_mfpc_labels(cloud.points, config.structures);
        expected_raw = reference::reference_raw_labels(cloud.points, config.structures);
    } catch (const Error&) {
        return 0;  // level_box refused a level: the kernels must refuse it too (checked below).
    }
    std::sort(expected_raw.begin(), expected_raw.end(), [](const auto& a, const auto& b) {
        return std::tie(a.label.structure, a.point, a.label.level) < std::tie(b.label.structure, b.point, b.label.level);
    });

    try {
        const PointIndex index(cloud, {index_voxel});
        const FoveationRegions treated = foveation_regions(index, config.structures, FoveationMode::mfpc);
        fuzz::check(labels_from(treated, cloud.size()) == expected_labels, "mfpc labels differ from Algorithm 1");
        const FoveationRegions raw = foveation_regions(index, config.structures, FoveationMode::raw);
        fuzz::check(raw_from(raw) == expected_raw, "raw labels differ from the reference");
        fuzz::check(treated.redundant_points() == raw.members.size() - treated.members.size(),
                    "redundant points are not |raw| - |mfpc|");
        for (const Downsample mode : {Downsample::voxel, Downsample::uniform}) {
            check_downsampling(cloud, treated, config.structures, mode);
        }

        // The one-shot foveate: the same (label, source point) pairs as downsampling the regions.
        const FoveatedCloud once = foveate(cloud, config, FoveationMode::mfpc);
        const FoveatedCloud regions = downsample_regions(cloud, treated, config.structures, config.downsample);
        fuzz::check(once.cloud.size() == regions.cloud.size(), "one-shot foveate keeps another number of points");
        std::multiset<std::tuple<int, int, std::uint32_t>> a, b;
        for (std::size_t i = 0; i < once.cloud.size(); ++i) {
            a.insert({once.labels[i].structure, once.labels[i].level, once.cloud.source_index[i]});
            b.insert({regions.labels[i].structure, regions.labels[i].level, regions.cloud.source_index[i]});
        }
        fuzz::check(a == b, "one-shot foveate keeps other points than the regions");
        // And in the order of foveate() over an index of the whole cloud (the default voxel, which
        // the one-shot's order follows), with the same centroids up to how their sums are grouped.
        const PointIndex whole(cloud);
        for (const FoveationMode mode : {FoveationMode::mfpc, FoveationMode::raw}) {
            const FoveatedCloud one_shot = foveate(cloud, config, mode);
            const FoveatedCloud indexed = foveate(cloud, whole, config, mode);
            fuzz::check(one_shot.cloud.source_index == indexed.cloud.source_index && one_shot.labels == indexed.labels,
                        "one-shot foveate keeps its points in another order than over an index");
            for (std::size_t i = 0; i < one_shot.cloud.size(); ++i)
                fuzz::check((one_shot.cloud.points[i] - indexed.cloud.points[i]).norm() <=
                                1e-6f * (1.0f + indexed.cloud.points[i].norm()),
                            "one-shot foveate puts a centroid elsewhere than over an index");
        }
    } catch (const Error& error) {
        // The reference accepted every structure and the points are small and finite: the kernels
        // have no reason to refuse.
        fuzz::fail(std::string("foveation refused what the reference accepts: ") + error.what());
    }
    return 0;
}
