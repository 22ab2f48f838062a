#include "mfpc/kernels/foveate.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

constexpr std::int8_t outside = -1;
constexpr std::int8_t mixed = -2;
constexpr std::uint16_t no_region = std::numeric_limits<std::uint16_t>::max();

// The level of p from precomputed boxes: the largest k whose box contains p, or -1. The same rule
// as FoveatedStructure::level_of, without recomputing Eq. 7 and 8 per point.
int level_in(const Box* boxes, int box_count, const Point& p)
{
    for (int k = box_count - 1; k >= 0; --k) {
        if (boxes[k].contains(p)) return k;
    }
    return -1;
}

bool disjoint(const Box& a, const Box& b)
{
    return (a.max.array() < b.min.array()).any() || (a.min.array() > b.max.array()).any();
}

// The level shared by every point within `bounds` (tight bounds of a leaf), outside when no point
// can be in any box, or mixed. Exact: a leaf is level k only when its bounds lie in box k and miss
// every denser box, so it agrees with level_in point for point.
std::int8_t classify(const Box& bounds, const Box* boxes, int box_count)
{
    for (int k = box_count - 1; k >= 0; --k) {
        const Box& box = boxes[k];
        if (box.contains(bounds)) return std::int8_t(k);
        if (!disjoint(bounds, box)) return mixed;
    }
    return outside;
}

void check_structures(std::span<const FoveatedStructure> structures)
{
    if (structures.empty()) throw Error("foveation", "no structures");
    const int m = structures[0].levels;
    if (m < 1) throw Error("foveation", "levels must be at least 1, got " + std::to_string(m));
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

// Boxes and the densest-first order of every region, computed once per call.
struct RegionTable {
    int boxes_per_structure = 0;
    std::vector<Box> boxes;            // region r's box
    std::vector<std::uint16_t> rank;   // region r's place in the densest-first order
    std::vector<std::uint16_t> by_rank;

    explicit RegionTable(std::span<const FoveatedStructure> structures)
    {
        boxes_per_structure = structures[0].levels + 1;
        const std::size_t region_count = structures.size() * std::size_t(boxes_per_structure);
        boxes.resize(region_count);
        std::vector<float> density(region_count);
        for (std::size_t s = 0; s < structures.size(); ++s) {
            for (int k = 0; k < boxes_per_structure; ++k) {
                boxes[s * std::size_t(boxes_per_structure) + std::size_t(k)] = structures[s].level_box(k);
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

    const Box* boxes_of(int structure) const { return &boxes[std::size_t(structure * boxes_per_structure)]; }
    std::uint16_t region(int structure, int level) const
    {
        return std::uint16_t(structure * boxes_per_structure + level);
    }
};

struct Coverage {
    std::size_t covered_points = 0;
    std::size_t coverage_pairs = 0;
};

// Labels every point of the index with its densest covering region among `active` structures
// (no_region when none covers it). Decides as coarsely as it can: a leaf (then, inside a leaf that
// straddles a face, a voxel) is skipped when outside every structure and labelled whole when it
// lies in one region of every structure that reaches it; only points of voxels that straddle a face
// are tested one by one, and only against the structures that reach their voxel.
Coverage label_points(const PointIndex& index, const RegionTable& table, std::span<const int> active,
                      std::vector<std::uint16_t>& labels)
{
    const auto leaves = index.leaves();
    const auto voxels = index.voxels();
    const auto order = index.point_order();
    const auto ordered_points = index.ordered_points();
    const int box_count = table.boxes_per_structure;
    labels.assign(order.size(), no_region);
    std::uint16_t* const label = labels.data();

    struct Reach {
        int structure;
        std::int8_t code;  // the level of the whole leaf or voxel, or mixed
    };
    // Narrows `outer` (the structures reaching a leaf) to those reaching `bounds`; true if some are
    // still mixed there.
    auto narrow = [&](const std::vector<Reach>& outer, const Box& bounds, std::vector<Reach>& inner) {
        inner.clear();
        bool any_mixed = false;
        for (const Reach& r : outer) {
            const std::int8_t code = r.code == mixed ? classify(bounds, table.boxes_of(r.structure), box_count) : r.code;
            if (code == outside) continue;
            inner.push_back({r.structure, code});
            any_mixed |= code == mixed;
        }
        return any_mixed;
    };
    auto label_whole = [&](const std::vector<Reach>& reach, std::uint32_t begin, std::uint32_t end, Coverage& coverage) {
        std::uint16_t best = no_region;
        for (const Reach& r : reach) best = std::min(best, table.rank[table.region(r.structure, r.code)]);
        const std::uint16_t region = table.by_rank[best];
        for (std::uint32_t k = begin; k < end; ++k) label[order[k]] = region;
        coverage.covered_points += end - begin;
        coverage.coverage_pairs += std::size_t(end - begin) * reach.size();
    };
    auto label_each = [&](const std::vector<Reach>& reach, std::uint32_t begin, std::uint32_t end, Coverage& coverage) {
        for (std::uint32_t k = begin; k < end; ++k) {
            const Point& p = ordered_points[k];
            std::uint16_t best = no_region;
            std::size_t covering = 0;
            for (const Reach& r : reach) {
                const int level = r.code == mixed ? level_in(table.boxes_of(r.structure), box_count, p) : r.code;
                if (level < 0) continue;
                ++covering;
                best = std::min(best, table.rank[table.region(r.structure, level)]);
            }
            if (covering == 0) continue;
            label[order[k]] = table.by_rank[best];
            ++coverage.covered_points;
            coverage.coverage_pairs += covering;
        }
    };

    std::vector<Reach> all;
    for (int s : active) all.push_back({s, mixed});
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, leaves.size(), 4), Coverage{},
        [&](const tbb::blocked_range<std::size_t>& range, Coverage coverage) {
            std::vector<Reach> leaf_reach;
            std::vector<Reach> voxel_reach;
            for (std::size_t leaf = range.begin(); leaf != range.end(); ++leaf) {
                const PointIndexLeaf& l = leaves[leaf];
                const bool leaf_mixed = narrow(all, l.bounds, leaf_reach);
                if (leaf_reach.empty()) continue;  // far from every structure: no point touched
                if (!leaf_mixed) {
                    label_whole(leaf_reach, l.begin, l.end, coverage);
                    continue;
                }
                for (std::uint32_t v = l.voxel_begin; v < l.voxel_end; ++v) {
                    const PointIndexVoxel& voxel = voxels[v];
                    const bool voxel_mixed = narrow(leaf_reach, voxel.bounds, voxel_reach);
                    if (voxel_reach.empty()) continue;
                    if (voxel_mixed) {
                        label_each(voxel_reach, voxel.begin, voxel.end, coverage);
                    } else {
                        label_whole(voxel_reach, voxel.begin, voxel.end, coverage);
                    }
                }
            }
            return coverage;
        },
        [](Coverage a, const Coverage& b) {
            a.covered_points += b.covered_points;
            a.coverage_pairs += b.coverage_pairs;
            return a;
        });
}

// Groups labelled points by region, ascending within each (a counting sort over fixed blocks of
// points, so the result does not depend on the thread count). Region r of the labels lands at
// region r + region_shift of `out`, whose offsets must have been sized.
void gather_members(std::span<const std::uint16_t> labels, int region_count, FoveationRegions& out,
                    std::size_t region_shift, std::uint32_t member_base)
{
    constexpr std::size_t block = 1 << 16;
    const std::size_t blocks = (labels.size() + block - 1) / block;
    const std::size_t regions = std::size_t(region_count);
    std::vector<std::uint32_t> counts(blocks * regions, 0);
    tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
        // One spare counter takes the unlabelled points, so the loop has no branch.
        std::vector<std::uint32_t> local(regions + 1, 0);
        const std::size_t end = std::min(labels.size(), (b + 1) * block);
        for (std::size_t i = b * block; i < end; ++i) ++local[std::min<std::size_t>(labels[i], regions)];
        std::copy(local.begin(), local.end() - 1, &counts[b * regions]);
    });
    std::uint32_t total = member_base;
    for (std::size_t r = 0; r < regions; ++r) {
        out.offsets[region_shift + r] = total;
        for (std::size_t b = 0; b < blocks; ++b) {
            const std::uint32_t c = counts[b * regions + r];
            counts[b * regions + r] = total;
            total += c;
        }
    }
    out.offsets[region_shift + regions] = total;
    out.members.resize(total);
    std::uint32_t* const members = out.members.data();
    const std::uint16_t* const label = labels.data();
    tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
        std::uint32_t* cursor = &counts[b * regions];
        const std::size_t end = std::min(labels.size(), (b + 1) * block);
        for (std::size_t i = b * block; i < end; ++i) {
            if (label[i] != no_region) members[cursor[label[i]]++] = std::uint32_t(i);
        }
    });
}

}  // namespace

FoveationRegions foveation_regions(const PointIndex& index, std::span<const FoveatedStructure> structures,
                                   FoveationMode mode, int single_structure)
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
    const int region_count = out.region_count();
    out.offsets.assign(std::size_t(region_count) + 1, 0);
    const RegionTable table(structures);
    std::vector<std::uint16_t> labels;

    if (mode == FoveationMode::single) {
        const int active[] = {single_structure};
        const Coverage coverage = label_points(index, table, active, labels);
        gather_members(labels, region_count, out, 0, 0);
        out.covered_points = coverage.covered_points;
        out.coverage_pairs = coverage.coverage_pairs;
        return out;
    }

    std::vector<int> all(static_cast<std::size_t>(structure_count));
    std::iota(all.begin(), all.end(), 0);
    const Coverage coverage = label_points(index, table, all, labels);
    out.covered_points = coverage.covered_points;
    out.coverage_pairs = coverage.coverage_pairs;
    if (mode == FoveationMode::mfpc) {
        gather_members(labels, region_count, out, 0, 0);
        return out;
    }

    // raw: every structure on its own, concatenated in structure order.
    const int boxes_per_structure = out.levels + 1;
    std::uint32_t base = 0;
    FoveationRegions single;
    single.offsets.assign(std::size_t(region_count) + 1, 0);
    std::vector<std::uint32_t> members;
    for (int s = 0; s < structure_count; ++s) {
        const int active[] = {s};
        label_points(index, table, active, labels);
        gather_members(labels, region_count, single, 0, 0);
        const auto first = single.offsets[std::size_t(s * boxes_per_structure)];
        const auto last = single.offsets[std::size_t((s + 1) * boxes_per_structure)];
        for (int k = 0; k < boxes_per_structure; ++k) {
            out.offsets[std::size_t(s * boxes_per_structure + k)] =
                base + single.offsets[std::size_t(s * boxes_per_structure + k)] - first;
        }
        members.insert(members.end(), single.members.begin() + first, single.members.begin() + last);
        base += last - first;
    }
    out.offsets[std::size_t(region_count)] = base;
    out.members = std::move(members);
    return out;
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

// Finds the slot of a voxel (i, j, k), relative to the region's lowest voxel, creating it when new.
// A dense array over the region's voxel range when that range is small next to the member count,
// else an open-addressing hash of the packed key; both give the same slots.
class VoxelSlots {
public:
    static constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();

    VoxelSlots(const Eigen::Matrix<std::int64_t, 3, 1>& extent, std::size_t members) : extent_(extent)
    {
        const double cells = double(extent[0]) * double(extent[1]) * double(extent[2]);
        if (cells <= 4.0 * double(members) + 4096.0) {
            dense_.assign(std::size_t(cells), none);
        } else {
            capacity_ = std::bit_ceil(members * 2);
            shift_ = 64 - std::countr_zero(capacity_);
            keys_.assign(capacity_, empty_key);
            slots_.resize(capacity_);
        }
    }

    // The slot of voxel (i, j, k); `next` is the slot a new voxel gets. Returns {slot, is_new}.
    std::pair<std::uint32_t, bool> find(std::int64_t i, std::int64_t j, std::int64_t k, std::uint32_t next)
    {
        if (!dense_.empty()) {
            std::uint32_t& slot = dense_[std::size_t((i * extent_[1] + j) * extent_[2] + k)];
            if (slot != none) return {slot, false};
            slot = next;
            return {next, true};
        }
        const std::uint64_t key = (std::uint64_t(i) << 42) | (std::uint64_t(j) << 21) | std::uint64_t(k);
        std::size_t h = std::size_t((key * 0x9E3779B97F4A7C15ull) >> shift_);
        while (keys_[h] != key && keys_[h] != empty_key) h = (h + 1) & (capacity_ - 1);
        if (keys_[h] == key) return {slots_[h], false};
        keys_[h] = key;
        slots_[h] = next;
        return {next, true};
    }

private:
    static constexpr std::uint64_t empty_key = std::numeric_limits<std::uint64_t>::max();
    Eigen::Matrix<std::int64_t, 3, 1> extent_;
    std::vector<std::uint32_t> dense_;
    std::size_t capacity_ = 0;
    int shift_ = 0;
    std::vector<std::uint64_t> keys_;
    std::vector<std::uint32_t> slots_;
};

constexpr std::int64_t max_voxels_per_axis = std::int64_t(1) << 21;

// The voxel coordinate of x: floor(x * (1 / d)) in double, a multiplication by the inverse voxel
// size as PCL's VoxelGrid does. The floor is written out because on baseline x86-64 std::floor is a
// library call, which dominated the downsampling loop. Exact for |x / d| < 2^62.
inline std::int64_t voxel_of(float x, double inverse)
{
    const double q = double(x) * inverse;
    const auto t = static_cast<std::int64_t>(q);
    return t - (double(t) > q);
}

// Downsamples the members of one region, all inside `box` (the region's level box). Voxels are kept
// in first-occurrence order; members come ascending, so each voxel's sums run in ascending point
// index (as the reference's) and its first member is its lowest index.
RegionOutput downsample_region(const PointCloud& cloud, std::span<const std::uint32_t> members, const Box& box,
                               float density, Downsample downsample, int structure, int level)
{
    RegionOutput out;
    if (members.empty()) return out;
    if (density == 0.0f) {
        for (std::uint32_t point : members) keep_point(cloud, point, out);
        return out;
    }

    // floor(x / d) is monotonic in x, so the box gives the voxel range of every member.
    const std::string where = "foveation: structure " + std::to_string(structure) + " level " + std::to_string(level);
    const double d = density;
    const double inverse = 1.0 / d;
    // Voxel coordinates beyond 2^62 would overflow the integer conversion.
    if (std::max(box.min.cwiseAbs().maxCoeff(), box.max.cwiseAbs().maxCoeff()) * inverse > 1e15) {
        throw Error(where, "coordinates too large for voxels of size " + std::to_string(density));
    }
    Eigen::Matrix<std::int64_t, 3, 1> lowest;
    Eigen::Matrix<std::int64_t, 3, 1> extent;
    for (int axis = 0; axis < 3; ++axis) {
        lowest[axis] = voxel_of(box.min[axis], inverse);
        extent[axis] = voxel_of(box.max[axis], inverse) - lowest[axis] + 1;
        if (extent[axis] > max_voxels_per_axis) {
            throw Error(where, "region spans more than 2^21 voxels of size " + std::to_string(density) + " on one axis");
        }
    }
    VoxelSlots slots(extent, members.size());

    // The voxel of a member, relative to the box's lowest voxel; a member outside the box (regions
    // not made by foveation_regions) is an error, not an out-of-range write.
    auto voxel = [&](const Point& p) {
        const Eigen::Matrix<std::int64_t, 3, 1> v(voxel_of(p.x(), inverse) - lowest[0],
                                                  voxel_of(p.y(), inverse) - lowest[1],
                                                  voxel_of(p.z(), inverse) - lowest[2]);
        if (std::uint64_t(v[0]) >= std::uint64_t(extent[0]) || std::uint64_t(v[1]) >= std::uint64_t(extent[1]) ||
            std::uint64_t(v[2]) >= std::uint64_t(extent[2])) {
            throw Error(where, "a member lies outside the region's box");
        }
        return v;
    };

    if (downsample == Downsample::uniform) {
        struct Nearest {
            std::uint32_t point;
            double distance;
        };
        std::vector<Nearest> voxels;
        for (std::uint32_t point : members) {
            const Point& p = cloud.points[point];
            const auto v = voxel(p);
            const Eigen::Vector3d center = ((v + lowest).cast<double>().array() + 0.5).matrix() * d;
            const double distance = (p.cast<double>() - center).squaredNorm();
            const auto [slot, is_new] = slots.find(v[0], v[1], v[2], std::uint32_t(voxels.size()));
            if (is_new) {
                voxels.push_back({point, distance});
            } else if (distance < voxels[slot].distance) {
                voxels[slot] = {point, distance};
            }
        }
        for (const Nearest& nearest : voxels) keep_point(cloud, nearest.point, out);
        return out;
    }

    struct Sum {
        Eigen::Vector3d xyz;
        std::uint32_t count;
        std::uint32_t first;
    };
    std::vector<Sum> voxels;
    std::vector<std::uint32_t> slot_of;  // per member, for the normal and colour sums
    const bool attributes = cloud.has_normals() || cloud.has_colors();
    if (attributes) slot_of.reserve(members.size());
    for (std::uint32_t point : members) {
        const Point& p = cloud.points[point];
        const auto v = voxel(p);
        const auto [slot, is_new] = slots.find(v[0], v[1], v[2], std::uint32_t(voxels.size()));
        if (is_new) {
            voxels.push_back({p.cast<double>(), 1, point});
        } else {
            voxels[slot].xyz += p.cast<double>();
            ++voxels[slot].count;
        }
        if (attributes) slot_of.push_back(slot);
    }

    out.points.reserve(voxels.size());
    out.sources.reserve(voxels.size());
    for (const Sum& sum : voxels) {
        out.points.push_back((sum.xyz / double(sum.count)).cast<float>());
        out.sources.push_back(cloud.source_position(sum.first));
    }
    // Normals and colours in a second pass, so the common xyz-only cloud pays nothing for them.
    if (cloud.has_normals()) {
        std::vector<Eigen::Vector3d> normal_sums(voxels.size(), Eigen::Vector3d::Zero());
        for (std::size_t m = 0; m < members.size(); ++m) normal_sums[slot_of[m]] += cloud.normals[members[m]].cast<double>();
        for (std::size_t v = 0; v < voxels.size(); ++v) {
            const double length = normal_sums[v].norm();
            out.normals.push_back(length > 0.0 ? Point((normal_sums[v] / length).cast<float>())
                                               : cloud.normals[voxels[v].first]);
        }
    }
    if (cloud.has_colors()) {
        std::vector<Eigen::Vector3d> color_sums(voxels.size(), Eigen::Vector3d::Zero());
        for (std::size_t m = 0; m < members.size(); ++m) {
            const Rgb& c = cloud.colors[members[m]];
            color_sums[slot_of[m]] += Eigen::Vector3d(c.r, c.g, c.b);
        }
        for (std::size_t v = 0; v < voxels.size(); ++v) {
            const Eigen::Vector3d mean = color_sums[v] / double(voxels[v].count);
            out.colors.push_back({std::uint8_t(std::lround(mean.x())), std::uint8_t(std::lround(mean.y())),
                                  std::uint8_t(std::lround(mean.z()))});
        }
    }
    return out;
}

}  // namespace

FoveatedCloud downsample_regions(const PointCloud& cloud, const FoveationRegions& regions,
                                 std::span<const FoveatedStructure> structures, Downsample downsample)
{
    if (int(structures.size()) != regions.structures) {
        throw Error("foveation", "regions were labelled for " + std::to_string(regions.structures) +
                                     " structures, downsampling got " + std::to_string(structures.size()));
    }
    const int region_count = regions.region_count();
    std::vector<RegionOutput> outputs(static_cast<std::size_t>(region_count));
    FoveatedCloud result;
    result.regions.resize(std::size_t(region_count));
    tbb::parallel_for(0, region_count, [&](int r) {
        const int s = r / (regions.levels + 1);
        const int k = r % (regions.levels + 1);
        const FoveatedStructure& structure = structures[std::size_t(s)];
        const float density = structure.density(k);
        const auto members = regions.region(s, k);
        outputs[std::size_t(r)] = downsample_region(cloud, members, structure.level_box(k), density, downsample, s, k);
        result.regions[std::size_t(r)] = {s, k, density, members.size(), outputs[std::size_t(r)].points.size()};
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
    result.labels.reserve(total);
    for (int r = 0; r < region_count; ++r) {
        const RegionOutput& o = outputs[std::size_t(r)];
        out.points.insert(out.points.end(), o.points.begin(), o.points.end());
        out.normals.insert(out.normals.end(), o.normals.begin(), o.normals.end());
        out.colors.insert(out.colors.end(), o.colors.begin(), o.colors.end());
        out.source_index.insert(out.source_index.end(), o.sources.begin(), o.sources.end());
        const RegionLabel label{std::int16_t(r / (regions.levels + 1)), std::int16_t(r % (regions.levels + 1))};
        result.labels.insert(result.labels.end(), o.points.size(), label);
    }
    result.points_before_downsampling = regions.members.size();
    result.redundant_points = regions.redundant_points();
    return result;
}

FoveatedCloud foveate(const PointCloud& cloud, const PointIndex& index, const FoveationConfig& config,
                      FoveationMode mode, int single_structure)
{
    if (index.points().data() != cloud.points.data() || index.points().size() != cloud.points.size()) {
        throw Error("foveation", "the index was not built over this cloud");
    }
    if (mode == FoveationMode::none) {
        FoveatedCloud result;
        result.cloud = cloud;
        result.labels.assign(cloud.size(), RegionLabel{});
        result.points_before_downsampling = cloud.size();
        return result;
    }
    const FoveationRegions regions = foveation_regions(index, config.structures, mode, single_structure);
    return downsample_regions(cloud, regions, config.structures, config.downsample);
}

}  // namespace mfpc
