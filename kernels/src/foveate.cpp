#include "mfpc/kernels/foveate.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

constexpr std::int8_t outside = -1;
constexpr std::int8_t mixed = -2;

// The level of p from precomputed boxes: the largest k whose box contains p, or -1. The same rule
// as FoveatedStructure::level_of, without recomputing Eq. 7 and 8 per point.
int level_in(std::span<const Box> boxes, const Point& p)
{
    for (int k = int(boxes.size()) - 1; k >= 0; --k) {
        if (boxes[std::size_t(k)].contains(p)) return k;
    }
    return -1;
}

bool disjoint(const Box& a, const Box& b)
{
    return (a.max.array() < b.min.array()).any() || (a.min.array() > b.max.array()).any();
}

// The level shared by every point within `bounds` (tight bounds of a leaf), outside when no point
// can be in any box, or mixed. Exact: a leaf is level k only when its bounds lie in box k and miss
// every denser box, so it agrees with level_in point for point even where rounding breaks nesting.
std::int8_t classify(const Box& bounds, std::span<const Box> boxes)
{
    const int m = int(boxes.size()) - 1;
    for (int k = m; k >= 0; --k) {
        const Box& box = boxes[std::size_t(k)];
        if (box.contains(bounds)) return std::int8_t(k);
        if (!disjoint(bounds, box)) return mixed;
    }
    return outside;
}

struct Candidate {
    int structure = -1;
    int level = -1;
};

// Chunks of leaves are the unit of parallel work; their size is fixed (not derived from the thread
// count) so that the output order is the same at any thread count.
constexpr std::size_t leaves_per_chunk = 32;

struct Chunk {
    std::vector<std::uint32_t> regions;  // emitted (region, point) pairs in emission order
    std::vector<std::uint32_t> points;
    std::vector<std::uint32_t> counts;   // per region
    std::size_t covered_points = 0;
    std::size_t coverage_pairs = 0;
};

void check_structures(std::span<const FoveatedStructure> structures)
{
    if (structures.empty()) throw Error("foveation", "no structures");
    const int m = structures[0].levels;
    if (m < 1) throw Error("foveation", "levels must be at least 1, got " + std::to_string(m));
    if (m > 100) throw Error("foveation", "levels must be at most 100, got " + std::to_string(m));
    for (std::size_t s = 1; s < structures.size(); ++s) {
        if (structures[s].levels != m) {
            throw Error("foveation", "structures have different levels (structure 0: " + std::to_string(m) +
                                         ", structure " + std::to_string(s) + ": " +
                                         std::to_string(structures[s].levels) + "); the paper needs one m");
        }
    }
    if (structures.size() > std::size_t(std::numeric_limits<std::int16_t>::max())) {
        throw Error("foveation", "too many structures (" + std::to_string(structures.size()) + ")");
    }
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
    const int boxes_per_structure = out.levels + 1;
    const int region_count = out.region_count();

    std::vector<int> active;
    if (mode == FoveationMode::single) {
        active.push_back(single_structure);
    } else {
        for (int s = 0; s < structure_count; ++s) active.push_back(s);
    }
    std::vector<Box> boxes(static_cast<std::size_t>(region_count));
    std::vector<float> density(static_cast<std::size_t>(region_count));
    for (int s = 0; s < structure_count; ++s) {
        for (int k = 0; k < boxes_per_structure; ++k) {
            boxes[std::size_t(out.region_id(s, k))] = structures[std::size_t(s)].level_box(k);
            density[std::size_t(out.region_id(s, k))] = structures[std::size_t(s)].density(k);
        }
    }
    auto boxes_of = [&](int s) {
        return std::span<const Box>(boxes).subspan(std::size_t(s * boxes_per_structure),
                                                   std::size_t(boxes_per_structure));
    };
    // Densest first: smaller d_k, then the higher level; equal candidates keep the earlier structure.
    auto better = [&](const Candidate& a, const Candidate& b) {
        if (b.structure < 0) return true;
        const float da = density[std::size_t(out.region_id(a.structure, a.level))];
        const float db = density[std::size_t(out.region_id(b.structure, b.level))];
        if (da != db) return da < db;
        return a.level > b.level;
    };

    const auto leaves = index.leaves();
    const auto order = index.point_order();
    const auto points = index.points();
    const std::size_t active_count = active.size();

    // Phase 1: the level of each whole leaf in each active structure (or outside, or mixed).
    std::vector<std::int8_t> codes(leaves.size() * active_count);
    tbb::parallel_for(std::size_t(0), leaves.size(), [&](std::size_t leaf) {
        for (std::size_t a = 0; a < active_count; ++a) {
            codes[leaf * active_count + a] = classify(leaves[leaf].bounds, boxes_of(active[a]));
        }
    });

    // Phase 2: per chunk of leaves, emit (region, point) pairs and count them per region.
    const std::size_t chunk_count = (leaves.size() + leaves_per_chunk - 1) / leaves_per_chunk;
    std::vector<Chunk> chunks(chunk_count);
    tbb::parallel_for(std::size_t(0), chunk_count, [&](std::size_t c) {
        Chunk& chunk = chunks[c];
        chunk.counts.assign(std::size_t(region_count), 0);
        std::vector<int> levels(active_count);
        auto emit_point = [&](std::uint32_t point) {
            int covering = 0;
            Candidate best;
            for (std::size_t a = 0; a < active_count; ++a) {
                if (levels[a] < 0) continue;
                ++covering;
                const Candidate candidate{active[a], levels[a]};
                if (mode == FoveationMode::mfpc) {
                    if (better(candidate, best)) best = candidate;
                } else {
                    const auto region = std::uint32_t(out.region_id(candidate.structure, candidate.level));
                    chunk.regions.push_back(region);
                    chunk.points.push_back(point);
                    ++chunk.counts[region];
                }
            }
            if (covering == 0) return;
            ++chunk.covered_points;
            chunk.coverage_pairs += std::size_t(covering);
            if (mode == FoveationMode::mfpc) {
                const auto region = std::uint32_t(out.region_id(best.structure, best.level));
                chunk.regions.push_back(region);
                chunk.points.push_back(point);
                ++chunk.counts[region];
            }
        };

        const std::size_t leaf_end = std::min(leaves.size(), (c + 1) * leaves_per_chunk);
        for (std::size_t leaf = c * leaves_per_chunk; leaf < leaf_end; ++leaf) {
            const std::int8_t* code = &codes[leaf * active_count];
            bool any_inside = false;
            bool any_mixed = false;
            for (std::size_t a = 0; a < active_count; ++a) {
                any_inside |= code[a] != outside;
                any_mixed |= code[a] == mixed;
            }
            if (!any_inside) continue;  // the common case far from every structure: no point touched
            const PointIndexLeaf& range = leaves[leaf];
            if (!any_mixed) {
                for (std::size_t a = 0; a < active_count; ++a) levels[a] = code[a];
                for (std::uint32_t k = range.begin; k < range.end; ++k) emit_point(order[k]);
                continue;
            }
            for (std::uint32_t k = range.begin; k < range.end; ++k) {
                const std::uint32_t point = order[k];
                for (std::size_t a = 0; a < active_count; ++a) {
                    levels[a] = code[a] == mixed ? level_in(boxes_of(active[a]), points[point]) : code[a];
                }
                emit_point(point);
            }
        }
    });

    // Phase 3: region-major offsets (chunk order within a region), then scatter.
    out.offsets.assign(std::size_t(region_count) + 1, 0);
    std::vector<std::uint32_t> starts(chunk_count * std::size_t(region_count));
    std::size_t total = 0;
    for (int r = 0; r < region_count; ++r) {
        out.offsets[std::size_t(r)] = std::uint32_t(total);
        for (std::size_t c = 0; c < chunk_count; ++c) {
            starts[c * std::size_t(region_count) + std::size_t(r)] = std::uint32_t(total);
            total += chunks[c].counts[std::size_t(r)];
        }
    }
    out.offsets[std::size_t(region_count)] = std::uint32_t(total);
    if (total >= std::numeric_limits<std::uint32_t>::max()) {
        throw Error("foveation", "more than 2^32 region members");
    }
    out.members.resize(total);
    tbb::parallel_for(std::size_t(0), chunk_count, [&](std::size_t c) {
        std::uint32_t* cursor = &starts[c * std::size_t(region_count)];
        const Chunk& chunk = chunks[c];
        for (std::size_t e = 0; e < chunk.points.size(); ++e) {
            out.members[cursor[chunk.regions[e]]++] = chunk.points[e];
        }
    });
    for (const Chunk& chunk : chunks) {
        out.covered_points += chunk.covered_points;
        out.coverage_pairs += chunk.coverage_pairs;
    }
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

struct VoxelEntry {
    std::uint64_t key;
    std::uint32_t point;
    bool operator<(const VoxelEntry& other) const
    {
        return key != other.key ? key < other.key : point < other.point;
    }
};

constexpr int key_bits = 21;
constexpr std::int64_t key_span = std::int64_t(1) << key_bits;

std::int64_t voxel_coordinate(float value, double density)
{
    return static_cast<std::int64_t>(std::floor(double(value) / density));
}

void keep_point(const PointCloud& cloud, std::uint32_t point, RegionOutput& out)
{
    out.points.push_back(cloud.points[point]);
    if (cloud.has_normals()) out.normals.push_back(cloud.normals[point]);
    if (cloud.has_colors()) out.colors.push_back(cloud.colors[point]);
    out.sources.push_back(cloud.source_position(point));
}

RegionOutput downsample_region(const PointCloud& cloud, std::span<const std::uint32_t> members, float density,
                               Downsample downsample, int structure, int level)
{
    RegionOutput out;
    if (members.empty()) return out;
    if (density == 0.0f) {
        for (std::uint32_t point : members) keep_point(cloud, point, out);
        return out;
    }

    // Voxel coordinates relative to the region's lowest voxel, packed 21 bits an axis, so one
    // 64-bit key orders voxels by (i, j, k).
    const double d = density;
    Eigen::Matrix<std::int64_t, 3, 1> lowest = Eigen::Matrix<std::int64_t, 3, 1>::Constant(
        std::numeric_limits<std::int64_t>::max());
    Eigen::Matrix<std::int64_t, 3, 1> highest = -lowest;
    for (std::uint32_t point : members) {
        for (int axis = 0; axis < 3; ++axis) {
            const std::int64_t v = voxel_coordinate(cloud.points[point][axis], d);
            lowest[axis] = std::min(lowest[axis], v);
            highest[axis] = std::max(highest[axis], v);
        }
    }
    if (((highest - lowest).array() >= key_span).any()) {
        throw Error("foveation: structure " + std::to_string(structure) + " level " + std::to_string(level),
                    "region spans more than 2^21 voxels of size " + std::to_string(density) + " on one axis");
    }
    std::vector<VoxelEntry> entries(members.size());
    for (std::size_t i = 0; i < members.size(); ++i) {
        const Point& p = cloud.points[members[i]];
        std::uint64_t key = 0;
        for (int axis = 0; axis < 3; ++axis) {
            key = (key << key_bits) | std::uint64_t(voxel_coordinate(p[axis], d) - lowest[axis]);
        }
        entries[i] = {key, members[i]};
    }
    // Keys are unique with the point index in them, so any sort gives the same order.
    if (entries.size() > 32768) {
        tbb::parallel_sort(entries.begin(), entries.end());
    } else {
        std::sort(entries.begin(), entries.end());
    }

    for (std::size_t begin = 0; begin < entries.size();) {
        std::size_t end = begin + 1;
        while (end < entries.size() && entries[end].key == entries[begin].key) ++end;
        if (downsample == Downsample::uniform) {
            const std::uint64_t key = entries[begin].key;
            const Eigen::Vector3d center(
                (double(std::int64_t(key >> (2 * key_bits)) + lowest[0]) + 0.5) * d,
                (double(std::int64_t((key >> key_bits) & (key_span - 1)) + lowest[1]) + 0.5) * d,
                (double(std::int64_t(key & (key_span - 1)) + lowest[2]) + 0.5) * d);
            std::uint32_t nearest = entries[begin].point;
            double nearest_distance = std::numeric_limits<double>::infinity();
            for (std::size_t e = begin; e < end; ++e) {
                const double distance = (cloud.points[entries[e].point].cast<double>() - center).squaredNorm();
                if (distance < nearest_distance) {
                    nearest_distance = distance;
                    nearest = entries[e].point;
                }
            }
            keep_point(cloud, nearest, out);
        } else {
            Eigen::Vector3d sum = Eigen::Vector3d::Zero();
            Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
            Eigen::Vector3d color_sum = Eigen::Vector3d::Zero();
            for (std::size_t e = begin; e < end; ++e) {
                const std::uint32_t point = entries[e].point;
                sum += cloud.points[point].cast<double>();
                if (cloud.has_normals()) normal_sum += cloud.normals[point].cast<double>();
                if (cloud.has_colors()) {
                    const Rgb& c = cloud.colors[point];
                    color_sum += Eigen::Vector3d(c.r, c.g, c.b);
                }
            }
            const double count = double(end - begin);
            out.points.push_back((sum / count).cast<float>());
            if (cloud.has_normals()) {
                const double length = normal_sum.norm();
                out.normals.push_back(length > 0.0 ? Point((normal_sum / length).cast<float>())
                                                   : cloud.normals[entries[begin].point]);
            }
            if (cloud.has_colors()) {
                const Eigen::Vector3d mean = color_sum / count;
                out.colors.push_back({std::uint8_t(std::lround(mean.x())), std::uint8_t(std::lround(mean.y())),
                                      std::uint8_t(std::lround(mean.z()))});
            }
            out.sources.push_back(cloud.source_position(entries[begin].point));
        }
        begin = end;
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
    // One task per region; large regions sort in parallel inside their task.
    tbb::parallel_for(0, region_count, [&](int r) {
        const int s = r / (regions.levels + 1);
        const int k = r % (regions.levels + 1);
        const float density = structures[std::size_t(s)].density(k);
        const auto members = regions.region(s, k);
        outputs[std::size_t(r)] = downsample_region(cloud, members, density, downsample, s, k);
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
