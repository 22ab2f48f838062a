#include "mfpc/kernels/foveate.hpp"

#include <algorithm>
#include <chrono>
#include <limits>
#include <optional>
#include <numeric>
#include <string>
#include <utility>

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
using detail::no_region;
using detail::Float4;
using detail::Int4;

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

// Whether the cloud's attributes have the sizes check_cloud asks for: the one-shot foveate checks
// the points themselves in its labelling pass instead of a pass of their own.
bool attribute_sizes_fit(const PointCloud& cloud)
{
    const std::size_t n = cloud.size();
    return (!cloud.has_normals() || cloud.normals.size() == n) && (!cloud.has_colors() || cloud.colors.size() == n) &&
           (cloud.source_index.empty() || cloud.source_index.size() == n);
}

// The one-shot foveate's labelling without an index: every point tested against the level boxes,
// each covered one listed (ascending) in its region(s), with the keys that rank a point as an index
// of the cloud would list it, so that downsampling emits what foveate() over that index does. None
// when the outer boxes reach beyond the index's lattice or span too many leaves to key. Throws as
// check_cloud when a point is not finite or out of range, or a source position out of the source.
struct KeyedRegions {
    FoveationRegions regions;
    detail::IndexKeys keys;
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
    KeyedRegions out{FoveationRegions{}, detail::IndexKeys{lattice, *numbering}};

    const int levels = structures[0].levels;
    const int boxes = levels + 1;
    const std::size_t region_count = structures.size() * std::size_t(boxes);
    const LevelFaces faces(structures);
    const std::vector<std::uint16_t> rank = detail::densest_first_ranks(structures);
    const int first_structure = mode == FoveationMode::single ? single_structure : 0;
    const int end_structure = mode == FoveationMode::single ? single_structure + 1 : int(structures.size());
    const bool raw = mode == FoveationMode::raw;
    const std::size_t source_size = cloud.source_size();
    // Regions travel through the passes as their densest-first ranks, so that the densest is the
    // smallest; `outside`, after every rank, is no region. Per structure, the rank of each of its
    // levels, after `outside` for level -1.
    const auto outside = std::int32_t(region_count);
    const std::size_t boxes_and_outside = std::size_t(boxes) + 1;
    std::vector<std::int32_t> level_rank(structures.size() * boxes_and_outside, outside);
    for (std::size_t s = 0; s < structures.size(); ++s) {
        for (std::size_t k = 0; k < std::size_t(boxes); ++k)
            level_rank[s * boxes_and_outside + k + 1] = rank[s * std::size_t(boxes) + k];
    }

    // Points four at a time, axis by axis: calls visit(structure, levels) for each active structure
    // that holds some of them, levels -1 in the lanes it does not hold (and past the cloud's end).
    // Returns whether every lane within the cloud's points is finite and within ±max_coordinate.
    const auto visit_group = [&](std::size_t i, auto&& visit) {
        Float4 x, y, z;
        const std::size_t n = std::min<std::size_t>(4, cloud.size() - i);
        if (n == 4) {
            // x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3
            Float4 a, b, c;
            detail::load(a, cloud.points[i].data());
            detail::load(b, cloud.points[i].data() + 4);
            detail::load(c, cloud.points[i].data() + 8);
            const Float4 ab_x = __builtin_shufflevector(a, b, 0, 3, 6, 6);
            const Float4 ab_y = __builtin_shufflevector(a, b, 1, 4, 7, 7);
            const Float4 ab_z = __builtin_shufflevector(a, b, 2, 5, 5, 5);
            x = __builtin_shufflevector(ab_x, c, 0, 1, 2, 5);
            y = __builtin_shufflevector(ab_y, c, 0, 1, 2, 6);
            z = __builtin_shufflevector(ab_z, c, 0, 1, 4, 7);
        } else {
            constexpr float nan = std::numeric_limits<float>::quiet_NaN();
            x = y = z = Float4{nan, nan, nan, nan};
            for (std::size_t l = 0; l < n; ++l) {
                x[l] = cloud.points[i + l].x();
                y[l] = cloud.points[i + l].y();
                z[l] = cloud.points[i + l].z();
            }
        }
        if (!LevelFaces::none_set(faces.in_outer_bounds(x, y, z))) {
            for (int s = first_structure; s < end_structure; ++s) {
                const Int4 level = faces.levels(s, x, y, z);
                if (!LevelFaces::none_set(level >= 0)) visit(s, level);
            }
        }
        const Int4 fit = (x <= max_coordinate) & (x >= -max_coordinate) & (y <= max_coordinate) &
                         (y >= -max_coordinate) & (z <= max_coordinate) & (z >= -max_coordinate);
        // Lanes past the cloud's end are NaN, which does not fit: they count as fitting.
        const Int4 beyond = Int4{0, 1, 2, 3} >= std::int32_t(n);
        return LevelFaces::none_set(~(fit | beyond));
    };
    // For four points: the rank of the region each joins (`outside`: none), the densest of the
    // structures holding it (redundancy treatment); or, in mode raw, join(lane, rank) for each
    // structure holding a lane, lanes in order within a structure. Adds each lane's covering
    // structures to `covering`; returns the fit as visit_group does.
    const auto join_group = [&](std::size_t i, Int4& covering, Int4& best, auto&& join) {
        best = Int4{} + outside;
        return visit_group(i, [&](int s, Int4 level) {
            covering -= level >= 0;
            const std::int32_t* ranks = &level_rank[std::size_t(s) * boxes_and_outside + 1];
            const Int4 r = {ranks[level[0]], ranks[level[1]], ranks[level[2]], ranks[level[3]]};
            if (!raw) {
                best = r < best ? r : best;
                return;
            }
            for (int l = 0; l < 4; ++l) {
                if (r[l] != outside) join(l, r[l]);
            }
        });
    };

    // Two passes over fixed blocks of the cloud (so the member order is the same at any thread
    // count): the first counts each block's members per region (and keeps each point's region
    // but in mode raw, where a point may join several), the second writes each member once where
    // the counts say, with no list per block and region to grow and then join.
    constexpr std::size_t block_size = 8192;  // a multiple of the group of 4
    const std::size_t block_count = (cloud.size() + block_size - 1) / block_size;
    // Per block, members per rank, and a last count for `outside` that none reads.
    const std::size_t counted = region_count + 1;
    std::vector<std::uint32_t> counts(block_count * counted, 0);
    std::vector<std::uint16_t> rank_of(raw ? 0 : cloud.size());
    struct BlockTally {
        std::size_t covered_points = 0;
        std::size_t coverage_pairs = 0;
        bool points_fit = true;  // finite, within ±max_coordinate, their source positions in the source
    };
    std::vector<BlockTally> tallies(block_count);
    tbb::parallel_for(std::size_t(0), block_count, [&](std::size_t b) {
        std::uint32_t* count = &counts[b * counted];
        const std::size_t end = std::min(cloud.size(), (b + 1) * block_size);
        bool fit = true;
        Int4 covered{};
        Int4 pairs{};
        for (std::size_t i = b * block_size; i < end; i += 4) {
            Int4 covering{};
            Int4 best;
            fit &= join_group(i, covering, best, [&](int, std::int32_t joined) { ++count[joined]; });
            covered -= covering > 0;
            pairs += covering;
            if (raw) continue;
            for (std::size_t l = 0; l < std::min<std::size_t>(4, end - i); ++l) {
                ++count[best[l]];
                rank_of[i + l] = std::uint16_t(best[l]);
            }
        }
        if (!cloud.source_index.empty()) {
            // The largest, through a plain pointer: GCC vectorizes this loop, not the one over the vector.
            const std::uint32_t* source = cloud.source_index.data();
            std::uint32_t largest = 0;
            for (std::size_t i = b * block_size; i < end; ++i) largest = std::max(largest, source[i]);
            fit &= largest < source_size;
        }
        const auto lane_sum = [](Int4 v) {
            return std::size_t(v[0]) + std::size_t(v[1]) + std::size_t(v[2]) + std::size_t(v[3]);
        };
        tallies[b] = {lane_sum(covered), lane_sum(pairs), fit};
    });
    FoveationRegions& regions = out.regions;
    for (const BlockTally& tally : tallies) {
        // check_cloud names the first point that does not fit.
        if (!tally.points_fit) check_cloud(cloud, "foveation");
        regions.covered_points += tally.covered_points;
        regions.coverage_pairs += tally.coverage_pairs;
    }

    // Each block's first place in each region: the regions in order, the blocks in order within one.
    regions.structures = int(structures.size());
    regions.levels = levels;
    regions.offsets.assign(region_count + 1, 0);
    std::uint32_t at = 0;
    for (std::size_t r = 0; r < region_count; ++r) {
        regions.offsets[r] = at;
        for (std::size_t b = 0; b < block_count; ++b) {
            std::uint32_t& count = counts[b * counted + rank[r]];
            at += std::exchange(count, at);
        }
    }
    regions.offsets[region_count] = at;
    regions.members.resize(at);
    tbb::parallel_for(std::size_t(0), block_count, [&](std::size_t b) {
        std::uint32_t* cursor = &counts[b * counted];
        const auto add = [&](std::size_t i, std::int32_t joined) {
            regions.members[cursor[joined]++] = std::uint32_t(i);
        };
        const std::size_t end = std::min(cloud.size(), (b + 1) * block_size);
        for (std::size_t i = b * block_size; i < end; i += raw ? 4 : 1) {
            if (!raw) {
                if (rank_of[i] != outside) add(i, rank_of[i]);
                continue;
            }
            Int4 covering{};
            Int4 best;
            join_group(i, covering, best, [&](int lane, std::int32_t joined) { add(i + std::size_t(lane), joined); });
        }
    });
    return out;
}

}  // namespace

FoveatedCloud foveate(const PointCloud& cloud, const FoveationConfig& config, FoveationMode mode,
                      int single_structure)
{
    if (mode == FoveationMode::none) return unfoveated(cloud);
    check_structures(config.structures);
    // The labelling below trusts the attribute sizes (the indexed path finds a mismatch in building
    // the index); it checks the points as it goes, so check_cloud runs only to name a misfit.
    if (!attribute_sizes_fit(cloud)) check_cloud(cloud, "foveation");
    if (mode == FoveationMode::single) check_single_structure(config.structures, single_structure);
    // Without an index: each point tested against the boxes, and downsampling told where an index
    // would list each member, so the result is the indexed path's.
    const auto start = std::chrono::steady_clock::now();
    if (std::optional<KeyedRegions> keyed = keyed_regions(cloud, config.structures, mode, single_structure)) {
        const auto labelled = std::chrono::steady_clock::now();
        FoveatedCloud result =
            downsample_labelled(cloud, keyed->regions, config.structures, config.downsample, &keyed->keys);
        result.label_ms = std::chrono::duration<double, std::milli>(labelled - start).count();
        result.downsample_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - labelled).count();
        return result;
    }
    check_cloud(cloud, "foveation");
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
