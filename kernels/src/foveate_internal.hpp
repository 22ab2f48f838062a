#pragma once

// Private to kernels/ (kernels/src is not installed): what the phases of foveation share. The
// public entry points and their checks are in foveate.cpp, labelling in foveate_label.cpp,
// downsampling in foveate_downsample.cpp.

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <span>
#include <vector>

#include "mfpc/kernels/detail/lanes.hpp"
#include "mfpc/index/detail/index_lattice.hpp"
#include "mfpc/kernels/foveate.hpp"

namespace mfpc::detail {

constexpr std::uint16_t no_region = std::numeric_limits<std::uint16_t>::max();

// The levels that points within some bounds can have in one structure: every such point's level
// (the largest k whose box contains it, -1 for none; FoveatedStructure::level_of) lies in
// [lowest, highest]. lowest == highest means one level for all of them; highest == -1, outside.
struct LevelRange {
    std::int8_t lowest = -1;
    std::int8_t highest = -1;
    bool whole() const { return lowest == highest; }
};

// x, y, z and an unused fourth lane (mfpc/kernels/detail/lanes.hpp). A comparison gives -1 in
// every lane where it holds, so subtracting its result counts.
inline Float4 axis_lanes(const Point& p) { return Float4{p.x(), p.y(), p.z(), 0.0f}; }
inline int smallest_axis(Int4 counts) { return std::min(std::min(counts[0], counts[1]), counts[2]); }

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
                lower_.push_back(Float4{box.min.x(), box.min.y(), box.min.z(), -inf});
                upper_.push_back(Float4{box.max.x(), box.max.y(), box.max.z(), inf});
                const auto lanes_of = [](float face) { return Float4{face, face, face, face}; };
                planes_.push_back({lanes_of(box.min.x()), lanes_of(box.max.x()), lanes_of(box.min.y()),
                                   lanes_of(box.max.y()), lanes_of(box.min.z()), lanes_of(box.max.z())});
            }
        }
        Box bounds = structures[0].level_box(0);
        for (const FoveatedStructure& structure : structures) bounds.extend(structure.level_box(0));
        for (int axis = 0; axis < 3; ++axis) {
            outer_bounds_[std::size_t(2 * axis)] = Float4{} + bounds.min[axis];
            outer_bounds_[std::size_t(2 * axis + 1)] = Float4{} + bounds.max[axis];
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
        const Float4* lower = lower_faces(structure);
        const Float4* upper = upper_faces(structure);
        const Float4 low = axis_lanes(bounds.min);
        const Float4 high = axis_lanes(bounds.max);
        // Bounds beside the outer box, the common case with many structures: no level to count.
        const Int4 beside = (high < lower[0]) | (low > upper[0]);
        if (beside[0] | beside[1] | beside[2]) return {-1, -1};
        const int first = known.lowest + 1;
        Int4 lower_in = Int4{} + first;
        Int4 upper_in = lower_in, lower_reach = lower_in, upper_reach = lower_in;
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
        const Float4* lower = lower_faces(structure);
        const Float4* upper = upper_faces(structure);
        const Float4 x = axis_lanes(p);
        const int first = known.lowest + 1;
        Int4 lower_in = Int4{} + first;
        Int4 upper_in = lower_in;
        for (int k = first; k <= known.highest; ++k) {
            lower_in -= lower[k] <= x;
            upper_in -= upper[k] >= x;
        }
        return smallest_axis(lower_in < upper_in ? lower_in : upper_in) - 1;
    }

    // The levels of four points at once, given axis by axis (lanes that are NaN lie outside): per
    // lane the number of the structure's boxes that hold the point, less one, which is its level as
    // the boxes are nested (-1: outside). Stops at the first box that holds none of them.
    Int4 levels(int structure, Float4 x, Float4 y, Float4 z) const
    {
        const std::array<Float4, 6>* planes = &planes_[std::size_t(structure) * std::size_t(boxes_)];
        Int4 count{};
        for (int k = 0; k < boxes_; ++k) {
            const std::array<Float4, 6>& f = planes[k];
            const Int4 in = (x >= f[0]) & (x <= f[1]) & (y >= f[2]) & (y <= f[3]) & (z >= f[4]) & (z <= f[5]);
            if (none_set(in)) break;
            count -= in;
        }
        return count - 1;
    }

    // For four points given axis by axis: the lanes inside the bounds of every structure's outer box,
    // which levels() can skip the structures for when none is.
    Int4 in_outer_bounds(Float4 x, Float4 y, Float4 z) const
    {
        const std::array<Float4, 6>& f = outer_bounds_;
        return (x >= f[0]) & (x <= f[1]) & (y >= f[2]) & (y <= f[3]) & (z >= f[4]) & (z <= f[5]);
    }

    // Whether no lane of a comparison's result holds (two 64-bit halves: reading the four lanes one
    // by one took as many instructions as the box test).
    static bool none_set(Int4 mask)
    {
        std::uint64_t half[2];
        std::memcpy(half, &mask, sizeof half);
        return (half[0] | half[1]) == 0;
    }

    // Whether box `level` of `structure` (closed) holds p.
    bool contains(int structure, int level, const Point& p) const
    {
        return in_box(axis_lanes(p), std::size_t(structure) * std::size_t(boxes_) + std::size_t(level))[0] != 0;
    }

    // Whether some structure's outer box (closed) holds p.
    bool covers(const Point& p) const
    {
        const Float4 x = axis_lanes(p);
        Int4 inside{};
        for (std::size_t box = 0; box < lower_.size(); box += std::size_t(boxes_)) inside |= in_box(x, box);
        return inside[0] != 0;
    }

private:
    // Lane 0 is non-zero when box `box` (closed) holds x on all three axes. The axes' verdicts are
    // gathered in lanes: read lane by lane, the compares compiled to branches and took twice the time.
    Int4 in_box(Float4 x, std::size_t box) const
    {
        const Int4 in = (x >= lower_[box]) & (x <= upper_[box]);
        return in & __builtin_shufflevector(in, in, 1, 2, 0, 3) & __builtin_shufflevector(in, in, 2, 0, 1, 3);
    }

    const Float4* lower_faces(int structure) const { return &lower_[std::size_t(structure) * std::size_t(boxes_)]; }
    const Float4* upper_faces(int structure) const { return &upper_[std::size_t(structure) * std::size_t(boxes_)]; }

    int boxes_;
    std::vector<Float4> lower_;  // [structure * boxes + k]
    std::vector<Float4> upper_;
    // Each box's faces, each in every lane (min x, max x, min y, max y, min z, max z): levels().
    std::vector<std::array<Float4, 6>> planes_;
    std::array<Float4, 6> outer_bounds_{};  // the same for the bounds of the outer boxes
};

// Throws unless structure `single_structure` exists (mode single).
void check_single_structure(std::span<const FoveatedStructure> structures, int single_structure);

// Per region r = structure * (m + 1) + level, its place in the densest-first order that redundancy
// treatment keeps a point by: smaller d_k, then the higher level, then the earlier structure. The
// structures must have passed check_structures.
std::vector<std::uint16_t> densest_first_ranks(std::span<const FoveatedStructure> structures);

// Throws unless the structures are usable together: at least one, one level count m in [1,
// max_levels], and few enough level regions for 16-bit region ids.
void check_structures(std::span<const FoveatedStructure> structures);

// foveation_regions, with or without the member list: downsampling needs only the runs, and
// foveate() leaves the members out (writing a list of every covered point, only to read the
// same points again through the runs, made foveation 9% slower).
FoveationRegions label_regions(const PointIndex& index, std::span<const FoveatedStructure> structures,
                               FoveationMode mode, int single_structure, bool with_members);

// Where a default PointIndex of a cloud would list a point: the key of its voxel (its leaf, then
// the voxel in the leaf; the index lists a voxel's points by ascending number). For points whose
// leaves lie within the numbering's.
struct IndexKeys {
    IndexLattice lattice;
    LeafNumbering numbering;
    std::uint64_t operator()(const Point& p) const { return numbering.key(lattice.voxel(p)); }
};

// Downsampling of regions known to be well formed: made by label_regions (the member list may be
// absent), or checked by downsample_regions. member_keys: none when the members come in the
// index's order; else the members come in ascending order and these keys rank them as an index
// would list them, so that the output is the same as from members in the index's order.
FoveatedCloud downsample_labelled(const PointCloud& cloud, const FoveationRegions& regions,
                                  std::span<const FoveatedStructure> structures, Downsample downsample,
                                  const IndexKeys* member_keys = nullptr);

}  // namespace mfpc::detail
