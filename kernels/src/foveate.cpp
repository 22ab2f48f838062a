#include "mfpc/kernels/foveate.hpp"

#include <algorithm>
#include <chrono>
#include <optional>
#include <numeric>
#include <string>

#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "mfpc/index/detail/index_lattice.hpp"
#include "foveate_internal.hpp"

namespace mfpc {

using detail::check_single_structure;
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

void detail::check_single_structure(std::span<const FoveatedStructure> structures, int single_structure)
{
    if (single_structure < 0 || std::size_t(single_structure) >= structures.size()) {
        throw Error("foveation", "structure " + std::to_string(single_structure) + " does not exist (config has " +
                                     std::to_string(structures.size()) + ")");
    }
}

std::vector<std::uint16_t> detail::densest_first_ranks(std::span<const FoveatedStructure> structures)
{
    const int boxes_per_structure = structures[0].levels + 1;
    const std::size_t region_count = structures.size() * std::size_t(boxes_per_structure);
    std::vector<float> density(region_count);
    for (std::size_t s = 0; s < structures.size(); ++s) {
        for (int k = 0; k < boxes_per_structure; ++k) {
            density[s * std::size_t(boxes_per_structure) + std::size_t(k)] = structures[s].density(k);
        }
    }
    // Densest first: smaller d_k, then the higher level, then the earlier structure (paper Eq. 6
    // keeps a point at the densest level covering it; the rest breaks ties deterministically).
    std::vector<std::uint16_t> by_rank(region_count);
    std::iota(by_rank.begin(), by_rank.end(), std::uint16_t(0));
    const int bps = boxes_per_structure;
    std::sort(by_rank.begin(), by_rank.end(), [&](std::uint16_t a, std::uint16_t b) {
        if (density[a] != density[b]) return density[a] < density[b];
        if (a % bps != b % bps) return a % bps > b % bps;
        return a / bps < b / bps;
    });
    std::vector<std::uint16_t> rank(region_count);
    for (std::size_t r = 0; r < region_count; ++r) rank[by_rank[r]] = std::uint16_t(r);
    return rank;
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

namespace {

// The one-shot foveate's labelling without an index: every point tested against the level boxes,
// each covered one listed (ascending) in its region(s) with the key that ranks it as an index of
// the cloud would list it, so that downsampling emits what foveate() over that index does. None
// when the outer boxes reach beyond the index's lattice or span too many leaves to key.
struct KeyedRegions {
    FoveationRegions regions;
    std::vector<std::uint64_t> keys;  // one per member
};
std::optional<KeyedRegions> keyed_regions(const PointCloud& cloud, std::span<const FoveatedStructure> structures,
                                          FoveationMode mode, int single_structure)
{
    const detail::IndexLattice lattice(PointIndexParams{}.voxel_size);
    Box outer = bounding_box(std::span<const Point>());
    for (const FoveatedStructure& structure : structures) outer.extend(structure.outer_box());
    // As PointIndex refuses points: farther than 2^30 voxels (or not finite).
    if (!lattice.reaches(outer.min) || !lattice.reaches(outer.max)) return std::nullopt;
    const std::optional<detail::LeafNumbering> numbering =
        detail::LeafNumbering::over(lattice.leaf(outer.min), lattice.leaf(outer.max));
    if (!numbering) return std::nullopt;

    const int levels = structures[0].levels;
    const int boxes = levels + 1;
    const std::size_t region_count = structures.size() * std::size_t(boxes);
    const LevelFaces faces(structures);
    const std::vector<std::uint16_t> rank = detail::densest_first_ranks(structures);
    const int first_structure = mode == FoveationMode::single ? single_structure : 0;
    const int end_structure = mode == FoveationMode::single ? single_structure + 1 : int(structures.size());
    const detail::LevelRange any_level{-1, std::int8_t(levels)};

    // Blocks of the cloud in parallel, each listing its members per region; joined in block order.
    struct Block {
        std::vector<std::vector<std::uint32_t>> members;
        std::vector<std::vector<std::uint64_t>> keys;
        std::size_t covered_points = 0;
        std::size_t coverage_pairs = 0;
    };
    constexpr std::size_t block_size = 16384;
    std::vector<Block> blocks((cloud.size() + block_size - 1) / block_size);
    tbb::parallel_for(std::size_t(0), blocks.size(), [&](std::size_t b) {
        Block& block = blocks[b];
        block.members.resize(region_count);
        block.keys.resize(region_count);
        for (std::size_t i = b * block_size, end = std::min(cloud.size(), i + block_size); i < end; ++i) {
            const Point& p = cloud.points[i];
            if (!faces.covers(p)) continue;
            std::size_t covering = 0;
            std::uint64_t key = 0;
            int densest = -1;
            const auto add = [&](int region) {
                block.members[std::size_t(region)].push_back(std::uint32_t(i));
                block.keys[std::size_t(region)].push_back(key);
            };
            for (int s = first_structure; s < end_structure; ++s) {
                const int level = faces.level(s, p, any_level);
                if (level < 0) continue;
                if (covering++ == 0) key = numbering->key(lattice.voxel(p));
                const int region = s * boxes + level;
                if (mode == FoveationMode::mfpc) {
                    if (densest < 0 || rank[std::size_t(region)] < rank[std::size_t(densest)]) densest = region;
                } else {
                    add(region);
                }
            }
            if (densest >= 0) add(densest);
            block.covered_points += covering > 0;
            block.coverage_pairs += covering;
        }
    });

    KeyedRegions out;
    FoveationRegions& regions = out.regions;
    regions.structures = int(structures.size());
    regions.levels = levels;
    regions.offsets.assign(region_count + 1, 0);
    for (std::size_t r = 0; r < region_count; ++r) {
        std::size_t count = 0;
        for (const Block& block : blocks) count += block.members[r].size();
        regions.offsets[r + 1] = regions.offsets[r] + std::uint32_t(count);
    }
    regions.members.resize(regions.offsets.back());
    out.keys.resize(regions.offsets.back());
    tbb::parallel_for(std::size_t(0), region_count, [&](std::size_t r) {
        std::size_t at = regions.offsets[r];
        for (const Block& block : blocks) {
            std::copy(block.members[r].begin(), block.members[r].end(), regions.members.begin() + std::ptrdiff_t(at));
            std::copy(block.keys[r].begin(), block.keys[r].end(), out.keys.begin() + std::ptrdiff_t(at));
            at += block.members[r].size();
        }
    });
    for (const Block& block : blocks) {
        regions.covered_points += block.covered_points;
        regions.coverage_pairs += block.coverage_pairs;
    }
    return out;
}

}  // namespace

FoveatedCloud foveate(const PointCloud& cloud, const FoveationConfig& config, FoveationMode mode,
                      int single_structure)
{
    if (mode == FoveationMode::none) return unfoveated(cloud);
    check_structures(config.structures);
    // The labelling below trusts the attribute sizes (the indexed path finds a mismatch in building
    // the index).
    check_cloud(cloud, "foveation");
    if (mode == FoveationMode::single) check_single_structure(config.structures, single_structure);
    // Without an index: each point tested against the boxes, and downsampling told where an index
    // would list each member, so the result is the indexed path's.
    const auto start = std::chrono::steady_clock::now();
    if (std::optional<KeyedRegions> keyed = keyed_regions(cloud, config.structures, mode, single_structure)) {
        const auto labelled = std::chrono::steady_clock::now();
        FoveatedCloud result = downsample_labelled(cloud, keyed->regions, config.structures, config.downsample, keyed->keys);
        result.label_ms = std::chrono::duration<double, std::milli>(labelled - start).count();
        result.downsample_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - labelled).count();
        return result;
    }
    // Outer boxes too far out to key (kilometres): index the points inside some outer box. Taken
    // in ascending order, they keep their relative order in the index (leaf, voxel, then point).
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
