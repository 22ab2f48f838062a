#include "mfpc/kernels/foveate.hpp"

#include <algorithm>
#include <chrono>
#include <string>

#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "foveate_internal.hpp"

namespace mfpc {

using detail::check_structures;
using detail::downsample_labelled;
using detail::label_regions;
using detail::LevelFaces;

void detail::check_structures(std::span<const FoveatedStructure> structures)
{
    if (structures.empty()) throw Error("foveation", "no structures");
    const int m = structures[0].levels;
    if (m < 1) throw Error("foveation", "levels must be at least 1, got " + std::to_string(m));
    // Levels travel as 8-bit numbers through the labelling (LevelRange).
    if (m > max_levels) {
        throw Error("foveation", "levels must be at most " + std::to_string(max_levels) + ", got " + std::to_string(m));
    }
    for (std::size_t s = 1; s < structures.size(); ++s) {
        if (structures[s].levels != m) {
            throw Error("foveation", "structures have different levels (structure 0: " + std::to_string(m) +
                                         ", structure " + std::to_string(s) + ": " +
                                         std::to_string(structures[s].levels) + "); the paper needs one m");
        }
    }
    // Region ids are 16-bit, with one value kept for "no region".
    if (structures.size() * std::size_t(m + 1) >= no_region) {
        throw Error("foveation", std::to_string(structures.size()) + " structures of " + std::to_string(m + 1) +
                                     " levels are more than 65,534 level regions");
    }
}

FoveationRegions foveation_regions(const PointIndex& index, std::span<const FoveatedStructure> structures,
                                   FoveationMode mode, int single_structure)
{
    return label_regions(index, structures, mode, single_structure, true);
}

namespace {

// Whether `offsets` are region_count + 1 ascending entries from 0 to `size`.
bool well_formed_offsets(const std::vector<std::uint32_t>& offsets, int region_count, std::size_t size)
{
    return offsets.size() == std::size_t(region_count) + 1 && offsets.front() == 0 && offsets.back() == size &&
           std::is_sorted(offsets.begin(), offsets.end());
}

}  // namespace

FoveatedCloud downsample_regions(const PointCloud& cloud, const FoveationRegions& regions,
                                 std::span<const FoveatedStructure> structures, Downsample downsample)
{
    if (int(structures.size()) != regions.structures) {
        throw Error("foveation", "regions were labelled for " + std::to_string(regions.structures) +
                                     " structures, downsampling got " + std::to_string(structures.size()));
    }
    check_structures(structures);
    if (regions.levels != structures[0].levels) {
        throw Error("foveation", "regions were labelled for " + std::to_string(regions.levels) +
                                     " levels, the structures have " + std::to_string(structures[0].levels));
    }
    const int region_count = regions.region_count();
    // Hand-made regions are checked as far as downsampling relies on them, so that a malformed one
    // is an error rather than a read out of bounds.
    if (!well_formed_offsets(regions.offsets, region_count, regions.members.size())) {
        throw Error("foveation", "region offsets do not partition the member list");
    }
    // Regions from foveation_regions name the cloud of their index; hand-made ones must at least
    // stay within the cloud.
    if (regions.index) {
        if (regions.index->points().data() != cloud.points.data() || regions.index->points().size() != cloud.size()) {
            throw Error("foveation", "the regions were labelled on another cloud");
        }
    } else if (!regions.members.empty() &&
               *std::max_element(regions.members.begin(), regions.members.end()) >= cloud.size()) {
        throw Error("foveation", "a region member is not a point of the cloud");
    }
    if (regions.index && !regions.run_offsets.empty()) {
        if (!well_formed_offsets(regions.run_offsets, region_count, regions.runs.size())) {
            throw Error("foveation", "region run offsets do not partition the runs");
        }
        // Whole-voxel runs are read voxel by voxel and point by point, so both must agree; a point
        // run need only stay within the index (a wrong voxel name sends it point by point).
        const auto voxels = regions.index->voxels();
        for (const RegionRun& run : regions.runs) {
            const bool fits = run.whole_voxels()
                                  ? run.voxel_end <= voxels.size() && run.begin == voxels[run.voxel_begin].begin &&
                                        run.end == voxels[run.voxel_end - 1].end
                                  : run.begin <= run.end && run.end <= regions.index->point_order().size();
            if (!fits) throw Error("foveation", "a region run does not fit the index");
        }
    }
    return downsample_labelled(cloud, regions, structures, downsample);
}

namespace {

FoveatedCloud unfoveated(const PointCloud& cloud)
{
    FoveatedCloud result;
    result.cloud = cloud;
    result.labels.assign(cloud.size(), RegionLabel{});
    result.points_before_downsampling = cloud.size();
    return result;
}

}  // namespace

FoveatedCloud foveate(const PointCloud& cloud, const PointIndex& index, const FoveationConfig& config,
                      FoveationMode mode, int single_structure)
{
    if (index.points().data() != cloud.points.data() || index.points().size() != cloud.points.size()) {
        throw Error("foveation", "the index was not built over this cloud");
    }
    if (mode == FoveationMode::none) return unfoveated(cloud);
    const auto start = std::chrono::steady_clock::now();
    const FoveationRegions regions = label_regions(index, config.structures, mode, single_structure, false);
    const auto labelled = std::chrono::steady_clock::now();
    FoveatedCloud result = downsample_labelled(cloud, regions, config.structures, config.downsample);
    result.label_ms = std::chrono::duration<double, std::milli>(labelled - start).count();
    const auto done = std::chrono::steady_clock::now();
    result.downsample_ms = std::chrono::duration<double, std::milli>(done - labelled).count();
    return result;
}

FoveatedCloud foveate(const PointCloud& cloud, const FoveationConfig& config, FoveationMode mode,
                      int single_structure)
{
    if (mode == FoveationMode::none) return unfoveated(cloud);
    check_structures(config.structures);
    // select() trusts the attribute sizes (the indexed path finds a mismatch in building the index).
    check_cloud(cloud, "foveation");
    // Only points inside some outer box can belong to a region. Taken in ascending order, they
    // keep their relative order in the index (leaf, voxel, then point), so labels, runs and
    // downsampling see the same points in the same order as over an index of the whole cloud.
    // Per block of the cloud, its covered points; the blocks joined in order.
    const LevelFaces faces(config.structures);
    constexpr std::size_t block = 16384;
    std::vector<std::vector<std::uint32_t>> block_covered((cloud.size() + block - 1) / block);
    tbb::parallel_for(std::size_t(0), block_covered.size(), [&](std::size_t b) {
        for (std::size_t i = b * block, end = std::min(cloud.size(), i + block); i < end; ++i)
            if (faces.covers(cloud.points[i])) block_covered[b].push_back(std::uint32_t(i));
    });
    std::vector<std::uint32_t> covered;
    for (const auto& part : block_covered) covered.insert(covered.end(), part.begin(), part.end());
    const PointCloud part = select(cloud, covered);
    const PointIndex index(part);
    // select() kept each point's source position, which is what the output reports.
    return foveate(part, index, config, mode, single_structure);
}

}  // namespace mfpc
