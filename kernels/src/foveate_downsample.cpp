#include <algorithm>
#include <array>
#include <limits>
#include <string>
#include <tuple>

#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/floor.hpp"
#include "foveate_internal.hpp"
#include "voxel_slots.hpp"

namespace mfpc {

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
    // None: the members come in the index's order. Else the members come in another order (the
    // one-shot foveate's, ascending), and (key of the point, member) ranks them as an index would
    // list them.
    const detail::IndexKeys* keys = nullptr;

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

// Where the index would list a member: its key, then its number.
struct IndexRank {
    std::uint64_t key = std::numeric_limits<std::uint64_t>::max();
    std::uint32_t point = std::numeric_limits<std::uint32_t>::max();
    bool operator<(const IndexRank& other) const { return key != other.key ? key < other.key : point < other.point; }
};

// The positions 0 .. ranks.size() - 1 ordered by rank: the order in which an index would list them.
std::vector<std::uint32_t> by_rank(const std::vector<IndexRank>& ranks)
{
    // Sorted with their ranks beside them: comparing through the positions read two ranks from
    // anywhere in `ranks` per comparison, about 6% of the one-shot foveate.
    struct Ranked {
        IndexRank rank;
        std::uint32_t position;
    };
    std::vector<Ranked> ranked(ranks.size());
    for (std::size_t i = 0; i < ranks.size(); ++i) ranked[i] = {ranks[i], std::uint32_t(i)};
    // Each rank names another point, so the order is total.
    std::sort(ranked.begin(), ranked.end(), [](const Ranked& a, const Ranked& b) { return a.rank < b.rank; });
    std::vector<std::uint32_t> order(ranks.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = ranked[i].position;
    return order;
}

// Downsamples the members of one region, all inside `box` (the region's level box). Voxels are kept
// in the order of their first member in the index's order; each voxel's sums run in member order
// (their double sums of float coordinates are exact, so the member order does not matter).
RegionOutput downsample_region(const PointCloud& cloud, const RegionMembers& region, const Box& box, float density,
                               Downsample downsample, int structure, int level)
{
    RegionOutput out;
    if (region.count == 0) return out;
    const bool keyed = region.keys != nullptr;
    if (density == 0.0f) {
        if (!keyed) {
            region.for_each(cloud, [&](std::uint32_t point, const Point&) { keep_point(cloud, point, out); });
            return out;
        }
        std::vector<IndexRank> ranks(region.count);
        for (std::size_t j = 0; j < region.count; ++j) {
            const std::uint32_t point = region.members[j];
            ranks[j] = {(*region.keys)(cloud.points[point]), point};
        }
        for (const std::uint32_t j : by_rank(ranks)) keep_point(cloud, region.members[j], out);
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
    // The one-shot foveate's regions are sized for a voxel per 16 members, not one per member: their
    // table is cleared on every call, and at 1 MB and more for ~1,000 voxels (real scene, 0.01 m)
    // its pages cost a cold call more than growing a smaller one does.
    detail::VoxelSlots slots(extent, keyed ? region.count / 16 : region.count);

    // The voxel of p relative to the box's lowest voxel, when p lies in the box's voxels. Checked
    // on the products, before the floors: floor(q) lies in [lowest, lowest + extent) exactly when
    // q does (integer bounds), and no far point (nor NaN) reaches an overflowing conversion.
    const Eigen::Array3d low_face = lowest.cast<double>();
    const Eigen::Array3d high_face = (lowest + extent).cast<double>();
    auto voxel_in_box = [&](const Point& p, Eigen::Matrix<std::int64_t, 3, 1>& v) __attribute__((always_inline)) {
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
        std::vector<IndexRank> first;  // keyed: per voxel, its first member in the index's order
        region.for_each(cloud, [&](std::uint32_t point, const Point& p) {
            const auto v = voxel(p);
            const Eigen::Vector3d center = ((v + lowest).cast<double>().array() + 0.5).matrix() * d;
            const double distance = (p.cast<double>() - center).squaredNorm();
            const auto [slot, is_new] = slots.find(v[0], v[1], v[2], std::uint32_t(voxels.size()));
            if (keyed) {
                if (is_new) first.emplace_back();
                first[slot] = std::min(first[slot], IndexRank{(*region.keys)(p), point});
            }
            // Strictly nearer, or as near with a lower index: the same point whatever the order.
            if (is_new) {
                voxels.push_back({point, distance});
            } else if (distance < voxels[slot].distance ||
                       (distance == voxels[slot].distance && point < voxels[slot].point)) {
                voxels[slot] = {point, distance};
            }
        });
        if (!keyed) {
            for (const Nearest& nearest : voxels) keep_point(cloud, nearest.point, out);
        } else {
            for (const std::uint32_t v : by_rank(first)) keep_point(cloud, voxels[v].point, out);
        }
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
    std::vector<IndexRank> first;  // keyed: per voxel, its first member in the index's order
    // The slot of the downsampling voxel holding all of `bounds` (tight bounds of index voxel
    // points, `first` the lowest of them), or none when they span several voxels or leave the
    // box's: the points then go one by one, where a member outside the box is an error.
    auto bounds_slot = [&](const Box& bounds, std::uint32_t first) __attribute__((always_inline)) {
        Eigen::Matrix<std::int64_t, 3, 1> v;
        if (!voxel_in_box(bounds.min, v) || !in_voxel(bounds.max, v)) return detail::VoxelSlots::none;
        return slot_for(v, first);
    };
    if (keyed) {
        // Written out rather than through the helpers above, which GCC 12 left out of line here (a
        // call per member, three times the instructions). Members ascend, so a voxel's first
        // member is its lowest point, and a later one ranks first in the index only by a lower key.
        // Consecutive members are mostly neighbouring pixels: a member in the previous one's
        // downsampling voxel (or index voxel) reuses its slot (or key) after a bounds test on the
        // same products the floors would take, in place of the floors, the lookup (or the key).
        first.reserve(voxels.capacity());
        const detail::IndexLattice& lattice = region.keys->lattice;
        // Whether low <= x < high on every axis.
        const auto within = [](const Eigen::Array3d& x, const Eigen::Array3d& low, const Eigen::Array3d& high) {
            return x[0] >= low[0] && x[1] >= low[1] && x[2] >= low[2] && x[0] < high[0] && x[1] < high[1] &&
                   x[2] < high[2];
        };
        Eigen::Array3d slot_low = Eigen::Array3d::Constant(std::numeric_limits<double>::infinity());
        Eigen::Array3d slot_high = slot_low;
        std::uint32_t slot = detail::VoxelSlots::none;
        Eigen::Array3d key_low = slot_low;
        Eigen::Array3d key_high = slot_low;
        std::uint64_t key = 0;
        for (std::size_t j = 0; j < region.count; ++j) {
            const std::uint32_t point = region.members[j];
            const Point& p = cloud.points[point];
            const Eigen::Array3d u = lattice.unfloored(p);
            const bool same_key = within(u, key_low, key_high);
            if (!same_key) {
                const Eigen::Vector3i iv(floor_to<int>(u.x()), floor_to<int>(u.y()), floor_to<int>(u.z()));
                key = region.keys->numbering.key(iv);
                key_low = iv.cast<double>().array();
                key_high = key_low + 1.0;
            }
            const Eigen::Array3d q = p.cast<double>().array() * inverse;
            if (within(q, slot_low, slot_high)) {
                Sum& sum = voxels[slot];
                sum.xyz += p.cast<double>();
                ++sum.count;
                if (!same_key && key < first[slot].key) first[slot] = {key, point};
            } else {
                Eigen::Matrix<std::int64_t, 3, 1> v;
                if (!voxel_in_box(p, v)) throw Error(where(), "a member lies outside the region's box");
                bool is_new = false;
                std::tie(slot, is_new) = slots.find(v[0], v[1], v[2], std::uint32_t(voxels.size()));
                slot_low = (v + lowest).cast<double>().array();
                slot_high = slot_low + 1.0;
                if (is_new) {
                    voxels.push_back({p.cast<double>(), 1, point});
                    first.push_back({key, point});
                } else {
                    Sum& sum = voxels[slot];
                    sum.xyz += p.cast<double>();
                    ++sum.count;
                    if (key < first[slot].key) first[slot] = {key, point};
                }
            }
            if (colors) {
                const Rgb& c = cloud.colors[point];
                std::array<std::uint64_t, 3>& rgb = voxels[slot].rgb;
                rgb[0] += c.r;
                rgb[1] += c.g;
                rgb[2] += c.b;
            }
            if (normals) slot_of.push_back(slot);
        }
    } else if (region.runs.empty()) {
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

    // The output order: first occurrence, which is the index's order unless keyed (then sorted).
    const std::vector<std::uint32_t> keyed_order = keyed ? by_rank(first) : std::vector<std::uint32_t>();
    auto in_order = [&](auto&& emit) {
        if (keyed) {
            for (const std::uint32_t v : keyed_order) emit(v);
        } else {
            for (std::uint32_t v = 0; v < voxels.size(); ++v) emit(v);
        }
    };
    out.points.reserve(voxels.size());
    out.sources.reserve(voxels.size());
    in_order([&](std::uint32_t v) {
        const Sum& sum = voxels[v];
        out.points.push_back((sum.xyz / double(sum.count)).cast<float>());
        out.sources.push_back(cloud.source_position(sum.first));
    });
    if (colors) {
        in_order([&](std::uint32_t v) {
            const Sum& sum = voxels[v];
            // Rounded to nearest: floor((2 sum + count) / (2 count)). In double, which is exact here
            // and much cheaper than a 64-bit division: both operands are integers below 2^45, and a
            // quotient below 256 that is not an integer is at least 2^-33 from one, far more than
            // its rounding error.
            auto mean = [&](std::uint64_t total) {
                return std::uint8_t((2.0 * double(total) + double(sum.count)) / (2.0 * double(sum.count)));
            };
            out.colors.push_back({mean(sum.rgb[0]), mean(sum.rgb[1]), mean(sum.rgb[2])});
        });
    }
    // Normals in a second pass, so clouds without them pay nothing.
    if (normals) {
        std::vector<Eigen::Vector3d> normal_sums(voxels.size(), Eigen::Vector3d::Zero());
        std::size_t m = 0;
        region.for_each(cloud, [&](std::uint32_t point, const Point&) {
            normal_sums[slot_of[m++]] += cloud.normals[point].cast<double>();
        });
        in_order([&](std::uint32_t v) {
            const double length = normal_sums[v].norm();
            out.normals.push_back(length > 0.0 ? Point((normal_sums[v] / length).cast<float>())
                                               : cloud.normals[voxels[v].first]);
        });
    }
    return out;
}

}  // namespace

FoveatedCloud detail::downsample_labelled(const PointCloud& cloud, const FoveationRegions& regions,
                                          std::span<const FoveatedStructure> structures, Downsample downsample,
                                          const IndexKeys* member_keys)
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
        RegionMembers region{count, {}, {}, regions.index, {}};
        if (use_runs) {
            region.runs = std::span<const RegionRun>(regions.runs)
                              .subspan(regions.run_offsets[std::size_t(r)],
                                       regions.run_offsets[std::size_t(r) + 1] - regions.run_offsets[std::size_t(r)]);
        }
        // Regions of runs list no members: the member list is empty there, and an offset into it
        // would be undefined even for an empty region.
        if (!use_runs) region.members = regions.region(s, k);
        region.keys = member_keys;
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

}  // namespace mfpc
