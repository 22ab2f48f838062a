#pragma once

// The reference (oracle) foveation: paper Algorithm 1 and the downsampling of each level region,
// written the obvious way (loops over structures, levels and every point, no index) so that the
// fast kernels can be checked against it bit for bit.
//
// Level semantics, shared with the kernels:
//  - Level region B_k of a structure is box k minus box k + 1 (B_m is the whole fovea box), boxes
//    from FoveatedStructure::level_box, closed on both ends. A point lies in at most one B_k of a
//    structure; a point in no box 0 is outside the structure (level -1).
//  - Redundancy treatment (mfpc mode, paper Eq. 6): a point covered by several structures is kept
//    once, at the densest level of any structure that covers it. "Densest" is ordered by
//      1. the smaller voxel size d_k (structure.density(k); 0, keep every point, is the densest),
//      2. then the higher level k (a structure with d_0 == d_m has all levels tied on d_k; its
//         inner levels also use the smaller keypoint radius, so they win),
//      3. then the lower structure index (the earlier structure in the config).
//  - Raw mode: each structure on its own, concatenated in structure order; a point in several
//    structures appears once per structure.
//  - Downsampling: a voxel grid aligned at the world origin. The voxel of p is
//    floor(double(p) * (1.0 / double(d))) per axis, computed in double and stored as a 64-bit
//    integer: a multiplication by the inverse voxel size, as PCL's VoxelGrid and UniformSampling
//    do (in float there), rather than a division. voxel mode keeps the centroid of each
//    voxel (summed in double, in increasing point index, rounded to float at the end); uniform mode
//    keeps the original point nearest the voxel centre (key + 0.5) * d, in double, ties to the
//    lowest point index. d == 0 keeps every point.
//  - Colours, when given, go with the points: a kept original point keeps its colour; a centroid
//    gets the per-channel mean of its voxel's colours rounded to nearest, halves up, as integers
//    (floor((2 sum + count) / (2 count))). The paper's pipeline downsamples coloured clouds this
//    way (PCL's VoxelGrid averages every field), so the reference does the same work as the kernels.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "mfpc/core/error.hpp"
#include "mfpc/core/foveated_structure.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc::reference {

// The level region of every point in one structure (-1 outside). Tests each point against box k
// and box k + 1 for every k, without FoveatedStructure::level_of, so that it checks level_of too.
// Throws when a point falls in two regions (the boxes would not be nested).
inline std::vector<int> reference_single_levels(std::span<const Point> points,
                                                const FoveatedStructure& structure)
{
    std::vector<int> levels(points.size(), -1);
    for (int level = 0; level <= structure.levels; ++level) {
        const Box box = structure.level_box(level);
        const bool innermost = level == structure.levels;
        const Box inner = innermost ? Box{} : structure.level_box(level + 1);
        for (std::size_t i = 0; i < points.size(); ++i) {
            const bool in_region = box.contains(points[i]) && (innermost || !inner.contains(points[i]));
            if (!in_region) continue;
            if (levels[i] != -1) {
                throw Error("reference_single_levels", "point " + std::to_string(i) +
                                                           " lies in two level regions");
            }
            levels[i] = level;
        }
    }
    return levels;
}

// Whether candidate (structure j, level k) is denser than the current choice, by the order above.
inline bool denser(std::span<const FoveatedStructure> structures, RegionLabel candidate,
                   RegionLabel current)
{
    if (current.structure < 0) return true;
    const float candidate_density = structures[candidate.structure].density(candidate.level);
    const float current_density = structures[current.structure].density(current.level);
    if (candidate_density != current_density) return candidate_density < current_density;
    if (candidate.level != current.level) return candidate.level > current.level;
    return candidate.structure < current.structure;
}

// Redundancy-treated labels (paper Eq. 6, Algorithm 1): one label per point, {-1, -1} for a point
// outside every structure.
inline std::vector<RegionLabel> reference_mfpc_labels(std::span<const Point> points,
                                                      std::span<const FoveatedStructure> structures)
{
    std::vector<RegionLabel> labels(points.size());
    for (std::size_t j = 0; j < structures.size(); ++j) {
        const std::vector<int> levels = reference_single_levels(points, structures[j]);
        for (std::size_t i = 0; i < points.size(); ++i) {
            if (levels[i] < 0) continue;
            const RegionLabel candidate{static_cast<std::int16_t>(j),
                                        static_cast<std::int16_t>(levels[i])};
            if (denser(structures, candidate, labels[i])) labels[i] = candidate;
        }
    }
    return labels;
}

struct RawLabel {
    std::uint32_t point = 0;
    RegionLabel label;
    friend bool operator==(const RawLabel&, const RawLabel&) = default;
};

// Raw labels: for each structure in order, each point it covers (in increasing point index) with
// its level. A point in several structures appears once per structure.
inline std::vector<RawLabel> reference_raw_labels(std::span<const Point> points,
                                                  std::span<const FoveatedStructure> structures)
{
    std::vector<RawLabel> raw;
    for (std::size_t j = 0; j < structures.size(); ++j) {
        const std::vector<int> levels = reference_single_levels(points, structures[j]);
        for (std::size_t i = 0; i < points.size(); ++i) {
            if (levels[i] < 0) continue;
            raw.push_back({static_cast<std::uint32_t>(i),
                           {static_cast<std::int16_t>(j), static_cast<std::int16_t>(levels[i])}});
        }
    }
    return raw;
}

using VoxelKey = std::array<std::int64_t, 3>;

// The voxel of p for voxel size d > 0: floor(double(p) * (1 / double(d))) per axis.
inline VoxelKey voxel_key(const Point& p, float d)
{
    const double inverse = 1.0 / double(d);
    return {static_cast<std::int64_t>(std::floor(double(p.x()) * inverse)),
            static_cast<std::int64_t>(std::floor(double(p.y()) * inverse)),
            static_cast<std::int64_t>(std::floor(double(p.z()) * inverse))};
}

struct Downsampled {
    // voxel mode: the centroids, sorted by voxel key (lexicographic x, y, z).
    // uniform mode and d == 0: the kept original points, in the order of `indices`.
    std::vector<Point> points;
    // uniform mode and d == 0: the kept original point indices, ascending. Empty in voxel mode
    // (a centroid is no original point).
    std::vector<std::uint32_t> indices;
    // The colours of `points`, when colours were given; empty otherwise.
    std::vector<Rgb> colors;
};

// Downsamples one level region (`region` holds point indices into `points`, each once) with voxel
// size d, per the rules in the header comment. `colors` is empty or one colour per point.
inline Downsampled reference_downsample(std::span<const Point> points,
                                        std::span<const std::uint32_t> region, float d,
                                        Downsample mode, std::span<const Rgb> colors = {})
{
    if (!(d >= 0.0f) || !std::isfinite(d)) {
        throw Error("reference_downsample", "voxel size must be finite and not negative");
    }
    if (!colors.empty() && colors.size() != points.size()) {
        throw Error("reference_downsample", "colours and points differ in number");
    }
    std::vector<std::uint32_t> sorted(region.begin(), region.end());
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
        throw Error("reference_downsample", "a point index appears twice in the region");
    }

    Downsampled result;
    if (d == 0.0f || mode == Downsample::uniform) {
        std::map<VoxelKey, std::uint32_t> nearest;  // voxel -> kept point
        if (d == 0.0f) {
            result.indices = sorted;
        } else {
            for (std::uint32_t index : sorted) {
                const VoxelKey key = voxel_key(points[index], d);
                const auto distance = [&](std::uint32_t candidate) {
                    double sum = 0.0;
                    for (int axis = 0; axis < 3; ++axis) {
                        const double center = (double(key[axis]) + 0.5) * double(d);
                        const double delta = double(points[candidate][axis]) - center;
                        sum += delta * delta;
                    }
                    return sum;
                };
                auto [it, inserted] = nearest.try_emplace(key, index);
                // Strictly nearer only: indices come in increasing order, so ties keep the lowest.
                if (!inserted && distance(index) < distance(it->second)) it->second = index;
            }
            for (const auto& entry : nearest) result.indices.push_back(entry.second);
            std::sort(result.indices.begin(), result.indices.end());
        }
        for (std::uint32_t index : result.indices) {
            result.points.push_back(points[index]);
            if (!colors.empty()) result.colors.push_back(colors[index]);
        }
        return result;
    }

    struct Sum {
        std::array<double, 3> xyz{};
        std::array<std::uint64_t, 3> rgb{};
        std::uint64_t count = 0;
    };
    std::map<VoxelKey, Sum> sums;  // ordered by key, lexicographic x, y, z
    for (std::uint32_t index : sorted) {
        Sum& sum = sums[voxel_key(points[index], d)];
        for (int axis = 0; axis < 3; ++axis) sum.xyz[axis] += double(points[index][axis]);
        if (!colors.empty()) {
            sum.rgb[0] += colors[index].r;
            sum.rgb[1] += colors[index].g;
            sum.rgb[2] += colors[index].b;
        }
        ++sum.count;
    }
    // Not a structured binding: clang 14 (the fuzz build) cannot capture one in the lambda below.
    for (const auto& entry : sums) {
        const Sum& sum = entry.second;
        const double count = double(sum.count);
        result.points.emplace_back(float(sum.xyz[0] / count), float(sum.xyz[1] / count),
                                   float(sum.xyz[2] / count));
        if (!colors.empty()) {
            const auto mean = [&](std::uint64_t total) {
                return std::uint8_t((2 * total + sum.count) / (2 * sum.count));
            };
            result.colors.push_back({mean(sum.rgb[0]), mean(sum.rgb[1]), mean(sum.rgb[2])});
        }
    }
    return result;
}

// The containment test of the authors' code, kept to show why it is wrong: it asks, axis by axis,
// whether p's coordinate lies in the outer-box range of any earlier structure, so x inside one box
// and y inside another counts as "inside". The reference above asks whether one box holds p.
inline bool per_axis_inside_any(const Point& p, std::span<const FoveatedStructure> structures_before)
{
    std::array<bool, 3> inside{};
    for (const FoveatedStructure& structure : structures_before) {
        const Box box = structure.level_box(0);
        for (int axis = 0; axis < 3; ++axis) {
            inside[axis] = inside[axis] || (p[axis] >= box.min[axis] && p[axis] <= box.max[axis]);
        }
    }
    return inside[0] && inside[1] && inside[2];
}

// The correct test: some earlier structure's outer box holds p.
inline bool whole_box_inside_any(const Point& p, std::span<const FoveatedStructure> structures_before)
{
    return std::any_of(structures_before.begin(), structures_before.end(),
                       [&](const FoveatedStructure& structure) {
                           return structure.level_box(0).contains(p);
                       });
}

}  // namespace mfpc::reference
