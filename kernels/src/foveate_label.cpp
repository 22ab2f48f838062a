#include <algorithm>
#include <bit>
#include <cassert>
#include <cstddef>
#include <numeric>
#include <string>

#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "foveate_internal.hpp"

namespace mfpc {

namespace {

using detail::LevelFaces;
using detail::LevelRange;
using detail::no_region;

// Level faces and the densest-first order of every region, computed once per call.
struct RegionTable {
    int boxes_per_structure = 0;
    LevelFaces faces;
    std::vector<std::uint16_t> rank;   // region r's place in the densest-first order
    std::vector<std::uint16_t> by_rank;

    explicit RegionTable(std::span<const FoveatedStructure> structures)
        : faces(structures), rank(detail::densest_first_ranks(structures))
    {
        boxes_per_structure = structures[0].levels + 1;
        by_rank.resize(rank.size());
        for (std::size_t r = 0; r < rank.size(); ++r) by_rank[rank[r]] = std::uint16_t(r);
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

}  // namespace

FoveationRegions detail::label_regions(const PointIndex& index, std::span<const FoveatedStructure> structures,
                                       FoveationMode mode, int single_structure, bool with_members)
{
    if (mode == FoveationMode::none) throw Error("foveation", "mode none has no level regions");
    check_structures(structures);
    const int structure_count = int(structures.size());
    if (mode == FoveationMode::single) detail::check_single_structure(structures, single_structure);

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

}  // namespace mfpc
