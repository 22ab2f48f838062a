#include "mfpc/kernels/foveate.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/floor.hpp"
#include "voxel_slots.hpp"

namespace mfpc {

namespace {

constexpr std::uint16_t no_region = std::numeric_limits<std::uint16_t>::max();

// The levels that points within some bounds can have in one structure: every such point's level
// (the largest k whose box contains it, -1 for none; FoveatedStructure::level_of) lies in
// [lowest, highest]. lowest == highest means one level for all of them; highest == -1, outside.
struct LevelRange {
    std::int8_t lowest = -1;
    std::int8_t highest = -1;
    bool whole() const { return lowest == highest; }
};

// x, y, z and an unused fourth lane (GCC/Clang vector extensions: SSE on x86-64, NEON on arm64).
// A comparison gives -1 in every lane where it holds, so subtracting its result counts.
using AxisLanes = float __attribute__((vector_size(16)));
using AxisCounts = std::int32_t __attribute__((vector_size(16)));

AxisLanes axis_lanes(const Point& p) { return AxisLanes{p.x(), p.y(), p.z(), 0.0f}; }
int smallest_axis(AxisCounts counts) { return std::min(std::min(counts[0], counts[1]), counts[2]); }

// The level boxes of every structure as faces, the three axes side by side. The boxes are nested,
// so on each axis the lower faces ascend with k and the upper ones descend: box k holds coordinate
// x on an axis exactly for k < min(#{j : lower_j <= x}, #{j : upper_j >= x}), and holds a point
// (or bounds) exactly when it does on all three axes. A level is thus a count of comparisons, made
// for the three axes at once and without a branch: written as box tests, labelling spent most of
// its time in mispredicted branches.
class LevelFaces {
public:
    explicit LevelFaces(std::span<const FoveatedStructure> structures) : boxes_(structures[0].levels + 1)
    {
        constexpr float inf = std::numeric_limits<float>::infinity();
        for (const FoveatedStructure& structure : structures) {
            for (int k = 0; k < boxes_; ++k) {
                const Box box = structure.level_box(k);
                // The fourth lane always holds, so it never limits the count.
                lower_.push_back(AxisLanes{box.min.x(), box.min.y(), box.min.z(), -inf});
                upper_.push_back(AxisLanes{box.max.x(), box.max.y(), box.max.z(), inf});
            }
        }
    }

    // The level range of points within `bounds` (tight: the extreme coordinates are points'), given
    // `known`, the range of some bounds enclosing them (all levels to start with). Only the boxes
    // in (known.lowest, known.highest] can cut them: those up to known.lowest hold the enclosing
    // bounds, those above known.highest miss them. On each axis the comparisons that hold form a
    // prefix of the boxes (the faces are nested), so each count starts at known.lowest + 1 and
    // stops at known.highest + 1, which no count of these bounds exceeds.
    LevelRange range(int structure, const Box& bounds, LevelRange known) const
    {
        const AxisLanes* lower = lower_faces(structure);
        const AxisLanes* upper = upper_faces(structure);
        const AxisLanes low = axis_lanes(bounds.min);
        const AxisLanes high = axis_lanes(bounds.max);
        // Bounds beside the outer box, the common case with many structures: no level to count.
        const AxisCounts beside = (high < lower[0]) | (low > upper[0]);
        if (beside[0] | beside[1] | beside[2]) return {-1, -1};
        const int first = known.lowest + 1;
        AxisCounts lower_in = AxisCounts{} + first;
        AxisCounts upper_in = lower_in, lower_reach = lower_in, upper_reach = lower_in;
        // Both counts in one pass over the faces (two passes cost labelling 4% more instructions).
        for (int k = first; k <= known.highest; ++k) {
            lower_in -= lower[k] <= low;
            upper_in -= upper[k] >= high;
            lower_reach -= lower[k] <= high;
            upper_reach -= upper[k] >= low;
        }
        // Boxes holding all of bounds, and boxes overlapping them.
        const int contained = smallest_axis(lower_in < upper_in ? lower_in : upper_in);
        const int reached = smallest_axis(lower_reach < upper_reach ? lower_reach : upper_reach);
        return {std::int8_t(contained - 1), std::int8_t(reached - 1)};
    }

    // The level of p (-1: outside the structure), given `known`, the range of bounds holding p.
    int level(int structure, const Point& p, LevelRange known) const
    {
        const AxisLanes* lower = lower_faces(structure);
        const AxisLanes* upper = upper_faces(structure);
        const AxisLanes x = axis_lanes(p);
        const int first = known.lowest + 1;
        AxisCounts lower_in = AxisCounts{} + first;
        AxisCounts upper_in = lower_in;
        for (int k = first; k <= known.highest; ++k) {
            lower_in -= lower[k] <= x;
            upper_in -= upper[k] >= x;
        }
        return smallest_axis(lower_in < upper_in ? lower_in : upper_in) - 1;
    }

    // Whether box `level` of `structure` (closed) holds p.
    bool contains(int structure, int level, const Point& p) const
    {
        return in_box(axis_lanes(p), std::size_t(structure) * std::size_t(boxes_) + std::size_t(level))[0] != 0;
    }

    // Whether some structure's outer box (closed) holds p.
    bool covers(const Point& p) const
    {
        const AxisLanes x = axis_lanes(p);
        AxisCounts inside{};
        for (std::size_t box = 0; box < lower_.size(); box += std::size_t(boxes_)) inside |= in_box(x, box);
        return inside[0] != 0;
    }

private:
    // Lane 0 is non-zero when box `box` (closed) holds x on all three axes. The axes' verdicts are
    // gathered in lanes: read lane by lane, the compares compiled to branches and took twice the time.
    AxisCounts in_box(AxisLanes x, std::size_t box) const
    {
        const AxisCounts in = (x >= lower_[box]) & (x <= upper_[box]);
        return in & __builtin_shufflevector(in, in, 1, 2, 0, 3) & __builtin_shufflevector(in, in, 2, 0, 1, 3);
    }

    const AxisLanes* lower_faces(int structure) const { return &lower_[std::size_t(structure) * std::size_t(boxes_)]; }
    const AxisLanes* upper_faces(int structure) const { return &upper_[std::size_t(structure) * std::size_t(boxes_)]; }

    int boxes_;
    std::vector<AxisLanes> lower_;  // [structure * boxes + k]
    std::vector<AxisLanes> upper_;
};

void check_structures(std::span<const FoveatedStructure> structures)
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

// Level faces and the densest-first order of every region, computed once per call.
struct RegionTable {
    int boxes_per_structure = 0;
    LevelFaces faces;
    std::vector<std::uint16_t> rank;   // region r's place in the densest-first order
    std::vector<std::uint16_t> by_rank;

    explicit RegionTable(std::span<const FoveatedStructure> structures) : faces(structures)
    {
        boxes_per_structure = structures[0].levels + 1;
        const std::size_t region_count = structures.size() * std::size_t(boxes_per_structure);
        std::vector<float> density(region_count);
        for (std::size_t s = 0; s < structures.size(); ++s) {
            for (int k = 0; k < boxes_per_structure; ++k) {
                density[s * std::size_t(boxes_per_structure) + std::size_t(k)] = structures[s].density(k);
            }
        }
        // Densest first: smaller d_k, then the higher level, then the earlier structure (paper Eq. 6
        // keeps a point at the densest level covering it; the rest breaks ties deterministically).
        by_rank.resize(region_count);
        std::iota(by_rank.begin(), by_rank.end(), std::uint16_t(0));
        const int bps = boxes_per_structure;
        std::sort(by_rank.begin(), by_rank.end(), [&](std::uint16_t a, std::uint16_t b) {
            if (density[a] != density[b]) return density[a] < density[b];
            if (a % bps != b % bps) return a % bps > b % bps;
            return a / bps < b / bps;
        });
        rank.resize(region_count);
        for (std::size_t r = 0; r < region_count; ++r) rank[by_rank[r]] = std::uint16_t(r);
    }

    std::uint16_t region(int structure, int level) const
    {
        return std::uint16_t(structure * boxes_per_structure + level);
    }
};

struct Coverage {
    std::size_t covered_points = 0;
    std::size_t coverage_pairs = 0;
};

// Chunks of leaves are the unit of parallel work; their size is fixed (not derived from the thread
// count), so the emitted order is the same at any thread count.
constexpr std::size_t leaves_per_chunk = 16;
// Voxels decided together inside a leaf that a face crosses (4 measured faster than 8 or 16).
constexpr std::uint32_t voxels_per_group = 4;

// What one chunk of leaves emitted: runs of the index's point order with their regions.
struct Emitted {
    std::vector<std::uint16_t> regions;
    std::vector<RegionRun> runs;
    Coverage coverage;
};

// Emits the densest covering region among `active` structures for every covered point of the index,
// as runs of its point order. Decides as coarsely as it can: a leaf (then, inside a leaf that
// straddles a face, a group of voxels, then a voxel) is skipped when outside every structure and
// emitted whole when it lies in one region of every structure that reaches it, or when the faces
// that cross it cannot change the densest region (dominated); only points of voxels where they can
// are tested one by one, and only against the structures that reach their voxel. Groups change
// how much is decided at once, never the runs emitted.
std::vector<Emitted> label_runs(const PointIndex& index, const RegionTable& table, std::span<const int> active)
{
    const auto leaves = index.leaves();
    const auto voxels = index.voxels();
    const auto ordered_points = index.ordered_points();
    const int box_count = table.boxes_per_structure;
    const LevelFaces& faces = table.faces;

    struct Reach {
        int structure;
        LevelRange levels;  // of the whole leaf or voxel
    };
    // Whether the points within some bounds all get one region although a face crosses them:
    // every structure in `reach` covers all of them (no outer face crosses), and one whose level
    // is the same for all of them is denser there than any level that one with several could
    // give. Redundancy treatment keeps that level whatever side of the faces a point lies on.
    // This is where structures overlap: on the real scene, it spares testing 38% of the points
    // that would otherwise be tested one by one.
    auto dominated = [&](const std::vector<Reach>& reach) {
        std::uint16_t single_best = no_region;
        for (const Reach& r : reach) {
            if (r.levels.lowest < 0) return false;
            if (!r.levels.whole()) continue;
            single_best = std::min(single_best, table.rank[table.region(r.structure, r.levels.lowest)]);
        }
        if (single_best == no_region) return false;
        for (const Reach& r : reach) {
            if (r.levels.whole()) continue;
            for (int k = r.levels.lowest; k <= r.levels.highest; ++k) {
                if (table.rank[table.region(r.structure, k)] < single_best) return false;
            }
        }
        return true;
    };
    // Narrows `outer` (the structures reaching a leaf) to those reaching `bounds`; true if some
    // structure still has more than one possible level there and it matters (not dominated).
    auto narrow = [&](const std::vector<Reach>& outer, const Box& bounds, std::vector<Reach>& inner) {
        inner.clear();
        bool any_mixed = false;
        for (const Reach& r : outer) {
            const LevelRange levels = r.levels.whole() ? r.levels : faces.range(r.structure, bounds, r.levels);
            if (levels.highest < 0) continue;
            inner.push_back({r.structure, levels});
            any_mixed |= !levels.whole();
        }
        return any_mixed && !dominated(inner);
    };
    // Appends a run, or extends the chunk's last run when it is of the same kind and region and
    // ends where this one begins: whole voxels across voxels (the index order is contiguous),
    // points tested one by one within their voxel (which the run names, for downsampling).
    auto emit = [](Emitted& out, std::uint16_t region, const RegionRun& run) {
        if (!out.runs.empty()) {
            RegionRun& last = out.runs.back();
            if (out.regions.back() == region && last.end == run.begin &&
                last.whole_voxels() == run.whole_voxels() && last.voxel_end == run.voxel_begin) {
                last.end = run.end;
                last.voxel_end = run.voxel_end;
                return;
            }
        }
        out.regions.push_back(region);
        out.runs.push_back(run);
    };
    auto emit_whole = [&](const std::vector<Reach>& reach, std::uint32_t voxel_begin, std::uint32_t voxel_end,
                          Emitted& out) {
        // narrow() keeps only structures that reach the bounds, so a whole range here has a level >= 0;
        // callers pass a non-empty voxel range (a leaf holds at least one voxel).
        assert(voxel_end > voxel_begin);
        std::uint16_t best = no_region;
        for (const Reach& r : reach) best = std::min(best, table.rank[table.region(r.structure, r.levels.lowest)]);
        const std::uint32_t begin = voxels[voxel_begin].begin;
        const std::uint32_t end = voxels[voxel_end - 1].end;
        emit(out, table.by_rank[best], RegionRun{begin, end, voxel_begin, voxel_end});
        out.coverage.covered_points += end - begin;
        out.coverage.coverage_pairs += std::size_t(end - begin) * reach.size();
    };
    auto emit_each = [&](const std::vector<Reach>& reach, std::uint32_t v, Emitted& out) {
        const PointIndexVoxel& voxel = voxels[v];
        // The common case: one structure with two possible levels here (one face crosses the
        // voxel), every other one with a single level. A point's region is then one of two,
        // chosen by one box test instead of the general loop below (0.16 of labelling's 0.40 ms
        // on the real scene). `mixed`: that structure's place in reach, -1 none yet, -2 not so.
        int mixed = -1;
        std::uint16_t fixed_best = no_region;
        std::size_t fixed_count = 0;
        for (std::size_t i = 0; i < reach.size(); ++i) {
            const Reach& r = reach[i];
            if (r.levels.whole()) {
                fixed_best = std::min(fixed_best, table.rank[table.region(r.structure, r.levels.lowest)]);
                ++fixed_count;
            } else {
                mixed = mixed == -1 && r.levels.highest == r.levels.lowest + 1 ? int(i) : -2;
            }
        }
        if (mixed >= 0) {
            const Reach& r = reach[std::size_t(mixed)];
            const std::uint16_t best_in = std::min(fixed_best, table.rank[table.region(r.structure, r.levels.highest)]);
            const bool covers_out = r.levels.lowest >= 0;
            const std::uint16_t best_out =
                covers_out ? std::min(fixed_best, table.rank[table.region(r.structure, r.levels.lowest)]) : fixed_best;
            // Dominated, but the structure's outer face crosses the voxel (which dominated()
            // leaves here): one region for every point, only the coverage needs the box test.
            if (best_in == best_out && best_in != no_region) {
                std::size_t inside = 0;
                for (std::uint32_t k = voxel.begin; k < voxel.end; ++k) {
                    inside += faces.contains(r.structure, r.levels.highest, ordered_points[k]);
                }
                out.coverage.covered_points += voxel.size();
                out.coverage.coverage_pairs += fixed_count * voxel.size() + inside;
                emit(out, table.by_rank[best_in], RegionRun{voxel.begin, voxel.end, v, v + 1});
                return;
            }
            // The box tests of up to 64 points first, as a bit mask (no branch), then one run per
            // stretch of points on the same side: a branch per point on its side mispredicted
            // wherever the face ran through the points' order.
            for (std::uint32_t block = voxel.begin; block < voxel.end; block += 64) {
                const std::uint32_t n = std::min<std::uint32_t>(64, voxel.end - block);
                std::uint64_t inside = 0;
                for (std::uint32_t i = 0; i < n; ++i) {
                    const bool in = faces.contains(r.structure, r.levels.highest, ordered_points[block + i]);
                    inside |= std::uint64_t(in) << i;
                }
                for (std::uint32_t i = 0; i < n;) {
                    const bool in = (inside >> i) & 1u;
                    // The stretch ends at the first point on the other side (bits past n are
                    // either side, hence the bound).
                    const std::uint64_t other_side = (in ? ~inside : inside) >> i;
                    const std::uint32_t length =
                        std::min<std::uint32_t>(n - i, other_side ? std::uint32_t(std::countr_zero(other_side)) : 64u);
                    const std::uint16_t best = in ? best_in : best_out;
                    if (best != no_region) {
                        out.coverage.covered_points += length;
                        out.coverage.coverage_pairs += length * (fixed_count + std::size_t(in || covers_out));
                        emit(out, table.by_rank[best], RegionRun{block + i, block + i + length, v, v});
                    }
                    i += length;
                }
            }
            return;
        }
        for (std::uint32_t k = voxel.begin; k < voxel.end; ++k) {
            std::uint16_t best = no_region;
            std::size_t covering = 0;
            for (const Reach& r : reach) {
                const int level = r.levels.whole() ? r.levels.lowest : faces.level(r.structure, ordered_points[k], r.levels);
                if (level < 0) continue;
                ++covering;
                best = std::min(best, table.rank[table.region(r.structure, level)]);
            }
            if (covering == 0) continue;
            out.coverage.covered_points += 1;
            out.coverage.coverage_pairs += covering;
            emit(out, table.by_rank[best], RegionRun{k, k + 1, v, v});
        }
    };

    std::vector<Reach> all;
    for (int s : active) all.push_back({s, LevelRange{-1, std::int8_t(box_count - 1)}});
    std::vector<Emitted> chunks((leaves.size() + leaves_per_chunk - 1) / leaves_per_chunk);
    tbb::parallel_for(std::size_t(0), chunks.size(), [&](std::size_t c) {
        Emitted& out = chunks[c];
        std::vector<Reach> leaf_reach;
        std::vector<Reach> group_reach;
        std::vector<Reach> voxel_reach;
        std::vector<Reach> chunk_reach;
        const std::size_t leaf_begin = c * leaves_per_chunk;
        const std::size_t leaf_end = std::min(leaves.size(), (c + 1) * leaves_per_chunk);
        // Structures that miss the chunk's leaves altogether are dropped once for all of them: with
        // 64 structures, narrowing every leaf against each was an eighth of labelling.
        Box chunk_bounds = leaves[leaf_begin].bounds;
        for (std::size_t leaf = leaf_begin + 1; leaf < leaf_end; ++leaf) {
            chunk_bounds.extend(leaves[leaf].bounds);
        }
        narrow(all, chunk_bounds, chunk_reach);
        if (chunk_reach.empty()) return;
        for (std::size_t leaf = leaf_begin; leaf < leaf_end; ++leaf) {
            const PointIndexLeaf& l = leaves[leaf];
            const bool leaf_mixed = narrow(chunk_reach, l.bounds, leaf_reach);
            if (leaf_reach.empty()) continue;  // far from every structure: no point touched
            if (!leaf_mixed) {
                emit_whole(leaf_reach, l.voxel_begin, l.voxel_end, out);
                continue;
            }
            // A face crosses the leaf: decide groups of consecutive voxels (neighbours in the
            // leaf's voxel order) by their joint bounds first, and only the voxels of groups that
            // a face crosses one by one. On the real scene three in five of these voxels lie in
            // groups decided whole.
            for (std::uint32_t group = l.voxel_begin; group < l.voxel_end; group += voxels_per_group) {
                const std::uint32_t group_end = std::min(l.voxel_end, group + voxels_per_group);
                Box bounds = voxels[group].bounds;
                for (std::uint32_t v = group + 1; v < group_end; ++v) {
                    bounds.extend(voxels[v].bounds);
                }
                const bool group_mixed = narrow(leaf_reach, bounds, group_reach);
                if (group_reach.empty()) continue;
                if (!group_mixed) {
                    emit_whole(group_reach, group, group_end, out);
                    continue;
                }
                for (std::uint32_t v = group; v < group_end; ++v) {
                    const bool voxel_mixed = narrow(group_reach, voxels[v].bounds, voxel_reach);
                    if (voxel_reach.empty()) continue;
                    if (voxel_mixed) {
                        emit_each(voxel_reach, v, out);
                    } else {
                        emit_whole(voxel_reach, v, v + 1, out);
                    }
                }
            }
        }
    });
    return chunks;
}

Coverage total_coverage(const std::vector<Emitted>& chunks)
{
    Coverage total;
    for (const Emitted& chunk : chunks) {
        total.covered_points += chunk.coverage.covered_points;
        total.coverage_pairs += chunk.coverage.coverage_pairs;
    }
    return total;
}

// Groups emitted runs by region (region-major, chunk order within a region) and, when asked,
// expands them into members.
void assemble(const std::vector<Emitted>& chunks, const PointIndex& index, bool with_members, FoveationRegions& out)
{
    const std::size_t regions = std::size_t(out.region_count());
    std::vector<std::uint32_t> run_starts(chunks.size() * regions, 0);
    std::vector<std::uint32_t> region_points(regions, 0);
    for (std::size_t c = 0; c < chunks.size(); ++c) {
        const Emitted& chunk = chunks[c];
        for (std::size_t e = 0; e < chunk.runs.size(); ++e) {
            ++run_starts[c * regions + chunk.regions[e]];
            region_points[chunk.regions[e]] += chunk.runs[e].end - chunk.runs[e].begin;
        }
    }
    out.run_offsets.assign(regions + 1, 0);
    out.offsets.assign(regions + 1, 0);
    std::uint32_t runs_total = 0;
    std::uint32_t points_total = 0;
    for (std::size_t r = 0; r < regions; ++r) {
        out.run_offsets[r] = runs_total;
        out.offsets[r] = points_total;
        points_total += region_points[r];
        for (std::size_t c = 0; c < chunks.size(); ++c) {
            const std::uint32_t count = run_starts[c * regions + r];
            run_starts[c * regions + r] = runs_total;
            runs_total += count;
        }
    }
    out.run_offsets[regions] = runs_total;
    out.offsets[regions] = points_total;
    out.runs.resize(runs_total);
    tbb::parallel_for(std::size_t(0), chunks.size(), [&](std::size_t c) {
        std::uint32_t* cursor = &run_starts[c * regions];
        const Emitted& chunk = chunks[c];
        for (std::size_t e = 0; e < chunk.runs.size(); ++e) out.runs[cursor[chunk.regions[e]]++] = chunk.runs[e];
    });
    out.index = &index;
    if (!with_members) return;
    out.members.resize(points_total);
    const auto order = index.point_order();
    tbb::parallel_for(std::size_t(0), regions, [&](std::size_t r) {
        std::uint32_t* member = out.members.data() + out.offsets[r];
        for (std::uint32_t i = out.run_offsets[r]; i < out.run_offsets[r + 1]; ++i) {
            const RegionRun& run = out.runs[i];
            member = std::copy(order.begin() + run.begin, order.begin() + run.end, member);
        }
    });
}

// foveation_regions, with or without the member list: downsampling needs only the runs, and
// foveate() leaves the members out (writing a list of every covered point, only to read the
// same points again through the runs, made foveation 9% slower).
FoveationRegions label_regions(const PointIndex& index, std::span<const FoveatedStructure> structures,
                               FoveationMode mode, int single_structure, bool with_members)
{
    if (mode == FoveationMode::none) throw Error("foveation", "mode none has no level regions");
    check_structures(structures);
    const int structure_count = int(structures.size());
    if (mode == FoveationMode::single && (single_structure < 0 || single_structure >= structure_count)) {
        throw Error("foveation", "structure " + std::to_string(single_structure) + " does not exist (config has " +
                                     std::to_string(structure_count) + ")");
    }

    FoveationRegions out;
    out.structures = structure_count;
    out.levels = structures[0].levels;
    const RegionTable table(structures);

    if (mode == FoveationMode::single) {
        const int active[] = {single_structure};
        const auto emitted = label_runs(index, table, active);
        const Coverage coverage = total_coverage(emitted);
        out.covered_points = coverage.covered_points;
        out.coverage_pairs = coverage.coverage_pairs;
        assemble(emitted, index, with_members, out);
        return out;
    }

    std::vector<int> all(static_cast<std::size_t>(structure_count));
    std::iota(all.begin(), all.end(), 0);
    auto emitted = label_runs(index, table, all);
    const Coverage coverage = total_coverage(emitted);
    out.covered_points = coverage.covered_points;
    out.coverage_pairs = coverage.coverage_pairs;
    if (mode == FoveationMode::mfpc) {
        assemble(emitted, index, with_members, out);
        return out;
    }

    // raw: every structure on its own, their regions concatenated in structure order.
    emitted.clear();
    const std::size_t levels = std::size_t(out.levels) + 1;
    out.offsets.assign(std::size_t(out.region_count()) + 1, 0);
    out.run_offsets.assign(std::size_t(out.region_count()) + 1, 0);
    std::uint32_t members = 0;
    for (int s = 0; s < structure_count; ++s) {
        const int active[] = {s};
        FoveationRegions single;
        single.structures = out.structures;
        single.levels = out.levels;
        assemble(label_runs(index, table, active), index, with_members, single);
        const std::size_t first = std::size_t(s) * levels;
        for (std::size_t r = first; r < first + levels; ++r) {
            out.offsets[r] = members + single.offsets[r] - single.offsets[first];
            out.run_offsets[r] = std::uint32_t(out.runs.size()) + single.run_offsets[r] - single.run_offsets[first];
        }
        members += single.offsets[first + levels] - single.offsets[first];
        if (with_members) {
            out.members.insert(out.members.end(), single.members.begin() + std::ptrdiff_t(single.offsets[first]),
                               single.members.begin() + std::ptrdiff_t(single.offsets[first + levels]));
        }
        out.runs.insert(out.runs.end(), single.runs.begin() + single.run_offsets[first],
                        single.runs.begin() + single.run_offsets[first + levels]);
    }
    out.offsets.back() = members;
    out.run_offsets.back() = std::uint32_t(out.runs.size());
    out.index = &index;
    return out;
}

}  // namespace

FoveationRegions foveation_regions(const PointIndex& index, std::span<const FoveatedStructure> structures,
                                   FoveationMode mode, int single_structure)
{
    return label_regions(index, structures, mode, single_structure, true);
}

namespace {

// One region's output before concatenation.
struct RegionOutput {
    std::vector<Point> points;
    std::vector<Point> normals;
    std::vector<Rgb> colors;
    std::vector<std::uint32_t> sources;
};

void keep_point(const PointCloud& cloud, std::uint32_t point, RegionOutput& out)
{
    out.points.push_back(cloud.points[point]);
    if (cloud.has_normals()) out.normals.push_back(cloud.normals[point]);
    if (cloud.has_colors()) out.colors.push_back(cloud.colors[point]);
    out.sources.push_back(cloud.source_position(point));
}

constexpr std::int64_t max_voxels_per_axis = std::int64_t(1) << 21;

// The voxel coordinate of x: floor(x * (1 / d)) in double, a multiplication by the inverse voxel
// size as PCL's VoxelGrid does. Exact for |x / d| < 2^62.
inline std::int64_t voxel_of(float x, double inverse) { return floor_to<std::int64_t>(double(x) * inverse); }

// The members of one region: index runs when the regions came from foveation_regions (points then
// read from the index's reordered copy; the member list may then be absent), else the plain
// member list.
struct RegionMembers {
    std::size_t count = 0;
    std::span<const std::uint32_t> members;
    std::span<const RegionRun> runs;  // empty: use members
    const PointIndex* index = nullptr;

    // Calls visit(point index, point) for every member, in member order.
    template <typename Visit>
    void for_each(const PointCloud& cloud, Visit&& visit) const
    {
        if (runs.empty()) {
            for (std::uint32_t point : members) visit(point, cloud.points[point]);
            return;
        }
        const auto order = index->point_order();
        const auto points = index->ordered_points();
        for (const RegionRun& run : runs) {
            for (std::uint32_t k = run.begin; k < run.end; ++k) visit(order[k], points[k]);
        }
    }
};

// Downsamples the members of one region, all inside `box` (the region's level box). Voxels are kept
// in first-occurrence order; each voxel's sums run in member order.
RegionOutput downsample_region(const PointCloud& cloud, const RegionMembers& region, const Box& box, float density,
                               Downsample downsample, int structure, int level)
{
    RegionOutput out;
    if (region.count == 0) return out;
    if (density == 0.0f) {
        region.for_each(cloud, [&](std::uint32_t point, const Point&) { keep_point(cloud, point, out); });
        return out;
    }

    // floor(x / d) is monotonic in x, so the box gives the voxel range of every member.
    // Built only when an error is thrown: this runs for every region of every call.
    const auto where = [&] {
        return "foveation: structure " + std::to_string(structure) + " level " + std::to_string(level);
    };
    const double d = density;
    const double inverse = 1.0 / d;
    // Voxel coordinates beyond 2^62 would overflow the integer conversion.
    if (std::max(box.min.cwiseAbs().maxCoeff(), box.max.cwiseAbs().maxCoeff()) * inverse > 1e15) {
        throw Error(where(), "coordinates too large for voxels of size " + format_number(density));
    }
    Eigen::Matrix<std::int64_t, 3, 1> lowest;
    Eigen::Matrix<std::int64_t, 3, 1> extent;
    for (int axis = 0; axis < 3; ++axis) {
        lowest[axis] = voxel_of(box.min[axis], inverse);
        extent[axis] = voxel_of(box.max[axis], inverse) - lowest[axis] + 1;
        if (extent[axis] > max_voxels_per_axis) {
            throw Error(where(), "region spans more than 2^21 voxels of size " + format_number(density) + " on one axis");
        }
    }
    detail::VoxelSlots slots(extent, region.count);

    // The voxel of p relative to the box's lowest voxel, when p lies in the box's voxels. Checked
    // on the products, before the floors: floor(q) lies in [lowest, lowest + extent) exactly when
    // q does (integer bounds), and no far point (nor NaN) reaches an overflowing conversion.
    const Eigen::Array3d low_face = lowest.cast<double>();
    const Eigen::Array3d high_face = (lowest + extent).cast<double>();
    auto voxel_in_box = [&](const Point& p, Eigen::Matrix<std::int64_t, 3, 1>& v) {
        const Eigen::Array3d q = p.cast<double>().array() * inverse;
        if (!(q[0] >= low_face[0] && q[1] >= low_face[1] && q[2] >= low_face[2] && q[0] < high_face[0] &&
              q[1] < high_face[1] && q[2] < high_face[2]))
            return false;
        v = Eigen::Matrix<std::int64_t, 3, 1>(floor_to<std::int64_t>(q[0]) - lowest[0], floor_to<std::int64_t>(q[1]) - lowest[1],
                                              floor_to<std::int64_t>(q[2]) - lowest[2]);
        return true;
    };
    // A member outside the box (regions not made by foveation_regions) is an error, not an
    // out-of-range write.
    auto voxel = [&](const Point& p) {
        Eigen::Matrix<std::int64_t, 3, 1> v;
        if (!voxel_in_box(p, v)) throw Error(where(), "a member lies outside the region's box");
        return v;
    };

    if (downsample == Downsample::uniform) {
        struct Nearest {
            std::uint32_t point;
            double distance;
        };
        std::vector<Nearest> voxels;
        region.for_each(cloud, [&](std::uint32_t point, const Point& p) {
            const auto v = voxel(p);
            const Eigen::Vector3d center = ((v + lowest).cast<double>().array() + 0.5).matrix() * d;
            const double distance = (p.cast<double>() - center).squaredNorm();
            const auto [slot, is_new] = slots.find(v[0], v[1], v[2], std::uint32_t(voxels.size()));
            // Strictly nearer, or as near with a lower index: the same point whatever the order.
            if (is_new) {
                voxels.push_back({point, distance});
            } else if (distance < voxels[slot].distance ||
                       (distance == voxels[slot].distance && point < voxels[slot].point)) {
                voxels[slot] = {point, distance};
            }
        });
        for (const Nearest& nearest : voxels) keep_point(cloud, nearest.point, out);
        return out;
    }

    struct Sum {
        Eigen::Vector3d xyz;
        std::uint32_t count;
        std::uint32_t first;                     // lowest point index
        std::array<std::uint64_t, 3> rgb{};      // integer sums: exact in any order
    };
    std::vector<Sum> voxels;
    // About one voxel per member, or per whole index voxel when they come as runs (a few split),
    // and at most one per downsampling voxel in the box: growing the table instead cost a tenth
    // of the region's time. Only a hint: the table still grows if index voxels split.
    std::size_t expected = region.count;
    if (!region.runs.empty()) {
        expected = 0;
        for (const RegionRun& run : region.runs) {
            expected += run.whole_voxels() ? run.voxel_end - run.voxel_begin : run.end - run.begin;
        }
    }
    voxels.reserve(std::size_t(std::min(double(expected), double(extent[0]) * double(extent[1]) * double(extent[2]))));
    const bool colors = cloud.has_colors();
    const bool normals = cloud.has_normals();
    std::vector<std::uint32_t> slot_of;  // per member, in member order, for the normal sums
    if (normals) slot_of.reserve(region.count);
    auto add_color = [&](Sum& sum, std::uint32_t point) {
        const Rgb& c = cloud.colors[point];
        sum.rgb[0] += c.r;
        sum.rgb[1] += c.g;
        sum.rgb[2] += c.b;
    };
    // The slot of voxel v, created (with `first` as its lowest point) when new. This and
    // bounds_slot are forced inline: GCC 12 kept one of them out of line (a call per index voxel),
    // which cost downsampling 9%.
    auto slot_for = [&](const Eigen::Matrix<std::int64_t, 3, 1>& v,
                        std::uint32_t first) __attribute__((always_inline)) {
        const auto [slot, is_new] = slots.find(v[0], v[1], v[2], std::uint32_t(voxels.size()));
        if (is_new) voxels.push_back({Eigen::Vector3d::Zero(), 0, first});
        return slot;
    };
    // Whether p, known to lie in voxel v or above it on every axis, lies in v: below its upper
    // faces, compared in double where the floor would be taken (v + lowest + 1 is exact there).
    // Three compares where the voxel of p would take three floors.
    auto in_voxel = [&](const Point& p, const Eigen::Matrix<std::int64_t, 3, 1>& v) {
        return double(p.x()) * inverse < double(v[0] + lowest[0] + 1) &&
               double(p.y()) * inverse < double(v[1] + lowest[1] + 1) &&
               double(p.z()) * inverse < double(v[2] + lowest[2] + 1);
    };
    auto add_to = [&](std::uint32_t slot, std::uint32_t point, const Point& p) {
        Sum& sum = voxels[slot];
        sum.xyz += p.cast<double>();
        ++sum.count;
        sum.first = std::min(sum.first, point);
        if (colors) add_color(sum, point);
        if (normals) slot_of.push_back(slot);
    };
    auto add_point = [&](std::uint32_t point, const Point& p) { add_to(slot_for(voxel(p), point), point, p); };
    // The slot of the downsampling voxel holding all of `bounds` (tight bounds of index voxel
    // points, `first` the lowest of them), or none when they span several voxels or leave the
    // box's: the points then go one by one, where a member outside the box is an error.
    auto bounds_slot = [&](const Box& bounds, std::uint32_t first) __attribute__((always_inline)) {
        Eigen::Matrix<std::int64_t, 3, 1> v;
        if (!voxel_in_box(bounds.min, v) || !in_voxel(bounds.max, v)) return detail::VoxelSlots::none;
        return slot_for(v, first);
    };
    if (region.runs.empty()) {
        region.for_each(cloud, add_point);
    } else {
        const auto order = region.index->point_order();
        const auto points = region.index->ordered_points();
        const auto index_voxels = region.index->voxels();
        const auto color_sums = region.index->sums_colors_of(cloud)
                                    ? region.index->voxel_color_sums()
                                    : std::span<const std::array<std::uint64_t, 3>>();
        for (const RegionRun& run : region.runs) {
            if (!run.whole_voxels()) {
                // Some points of one index voxel (foveation_regions names it; a run that is empty
                // or not within the voxel it names is taken point by point). When the voxel's
                // bounds fall in one downsampling voxel, so do these points: one lookup for all of
                // them. The voxel straddles a box face, so its bounds may leave the box's voxels.
                const std::uint32_t iv = run.voxel_begin;
                const bool named = run.begin < run.end && iv < index_voxels.size() &&
                                   index_voxels[iv].begin <= run.begin && run.end <= index_voxels[iv].end;
                const std::uint32_t slot =
                    named ? bounds_slot(index_voxels[iv].bounds, order[run.begin]) : detail::VoxelSlots::none;
                if (slot == detail::VoxelSlots::none) {
                    for (std::uint32_t k = run.begin; k < run.end; ++k) add_point(order[k], points[k]);
                    continue;
                }
                for (std::uint32_t k = run.begin; k < run.end; ++k) add_to(slot, order[k], points[k]);
                continue;
            }
            for (std::uint32_t iv = run.voxel_begin; iv < run.voxel_end; ++iv) {
                const PointIndexVoxel& index_voxel = index_voxels[iv];
                // A whole index voxel whose tight bounds fall in one downsampling voxel: one lookup
                // for all its points (ascending within the voxel, so the first is the lowest).
                const std::uint32_t slot = bounds_slot(index_voxel.bounds, order[index_voxel.begin]);
                if (slot == detail::VoxelSlots::none) {
                    for (std::uint32_t k = index_voxel.begin; k < index_voxel.end; ++k) add_point(order[k], points[k]);
                    continue;
                }
                Sum& sum = voxels[slot];
                sum.xyz += index_voxel.sum;
                if (!color_sums.empty()) {
                    for (int c = 0; c < 3; ++c) sum.rgb[c] += color_sums[iv][c];
                } else if (colors) {
                    for (std::uint32_t k = index_voxel.begin; k < index_voxel.end; ++k) add_color(sum, order[k]);
                }
                sum.count += index_voxel.size();
                sum.first = std::min(sum.first, order[index_voxel.begin]);
                if (normals) slot_of.insert(slot_of.end(), index_voxel.size(), slot);
            }
        }
    }

    out.points.reserve(voxels.size());
    out.sources.reserve(voxels.size());
    for (const Sum& sum : voxels) {
        out.points.push_back((sum.xyz / double(sum.count)).cast<float>());
        out.sources.push_back(cloud.source_position(sum.first));
    }
    if (colors) {
        for (const Sum& sum : voxels) {
            // Rounded to nearest: floor((2 sum + count) / (2 count)). In double, which is exact here
            // and much cheaper than a 64-bit division: both operands are integers below 2^45, and a
            // quotient below 256 that is not an integer is at least 2^-33 from one, far more than
            // its rounding error.
            auto mean = [&](std::uint64_t total) {
                return std::uint8_t((2.0 * double(total) + double(sum.count)) / (2.0 * double(sum.count)));
            };
            out.colors.push_back({mean(sum.rgb[0]), mean(sum.rgb[1]), mean(sum.rgb[2])});
        }
    }
    // Normals in a second pass, so clouds without them pay nothing.
    if (normals) {
        std::vector<Eigen::Vector3d> normal_sums(voxels.size(), Eigen::Vector3d::Zero());
        std::size_t m = 0;
        region.for_each(cloud, [&](std::uint32_t point, const Point&) {
            normal_sums[slot_of[m++]] += cloud.normals[point].cast<double>();
        });
        for (std::size_t v = 0; v < voxels.size(); ++v) {
            const double length = normal_sums[v].norm();
            out.normals.push_back(length > 0.0 ? Point((normal_sums[v] / length).cast<float>())
                                               : cloud.normals[voxels[v].first]);
        }
    }
    return out;
}

// Downsampling of regions known to be well formed: made by label_regions (the member list may be
// absent), or checked by downsample_regions.
FoveatedCloud downsample_labelled(const PointCloud& cloud, const FoveationRegions& regions,
                                  std::span<const FoveatedStructure> structures, Downsample downsample)
{
    const int region_count = regions.region_count();
    const bool use_runs = regions.index && !regions.run_offsets.empty();
    std::vector<RegionOutput> outputs(static_cast<std::size_t>(region_count));
    FoveatedCloud result;
    result.regions.resize(std::size_t(region_count));
    tbb::parallel_for(0, region_count, [&](int r) {
        const int s = r / (regions.levels + 1);
        const int k = r % (regions.levels + 1);
        const FoveatedStructure& structure = structures[std::size_t(s)];
        const float density = structure.density(k);
        const std::size_t count = regions.offsets[std::size_t(r) + 1] - regions.offsets[std::size_t(r)];
        RegionMembers region{count, {}, {}, regions.index};
        if (use_runs) {
            region.runs = std::span<const RegionRun>(regions.runs)
                              .subspan(regions.run_offsets[std::size_t(r)],
                                       regions.run_offsets[std::size_t(r) + 1] - regions.run_offsets[std::size_t(r)]);
        }
        if (region.runs.empty()) region.members = regions.region(s, k);
        outputs[std::size_t(r)] = downsample_region(cloud, region, structure.level_box(k), density, downsample, s, k);
        result.regions[std::size_t(r)] = {s, k, density, count, outputs[std::size_t(r)].points.size()};
    });

    std::size_t total = 0;
    for (const auto& o : outputs) total += o.points.size();
    PointCloud& out = result.cloud;
    out.width = cloud.width;
    out.height = cloud.height;
    out.points.reserve(total);
    out.source_index.reserve(total);
    if (cloud.has_normals()) out.normals.reserve(total);
    if (cloud.has_colors()) out.colors.reserve(total);
    // Sized once and filled per region: inserting copies of a label compiled to byte and half-word
    // stores followed by a whole-label reload for every element, a failed store forwarding each
    // time, which made this fill a tenth of downsampling.
    result.labels.resize(total);
    auto label_cursor = result.labels.begin();
    for (int r = 0; r < region_count; ++r) {
        const RegionOutput& o = outputs[std::size_t(r)];
        out.points.insert(out.points.end(), o.points.begin(), o.points.end());
        out.normals.insert(out.normals.end(), o.normals.begin(), o.normals.end());
        out.colors.insert(out.colors.end(), o.colors.begin(), o.colors.end());
        out.source_index.insert(out.source_index.end(), o.sources.begin(), o.sources.end());
        const RegionLabel label{std::int16_t(r / (regions.levels + 1)), std::int16_t(r % (regions.levels + 1))};
        label_cursor = std::fill_n(label_cursor, o.points.size(), label);
    }
    result.points_before_downsampling = regions.offsets.back();
    result.redundant_points = regions.redundant_points();
    return result;
}

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
