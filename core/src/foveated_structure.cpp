#include "mfpc/core/foveated_structure.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

std::string structure_where(const FoveatedStructure& structure)
{
    return structure.name.empty() ? std::string("foveated structure")
                                  : "foveated structure '" + structure.name + "'";
}

const char* axis_name(int axis)
{
    static const char* const names[] = {"x", "y", "z"};
    return names[axis];
}

void check_level(const FoveatedStructure& structure, int level)
{
    if (structure.levels < 1) {
        throw Error(structure_where(structure),
                    "levels is " + std::to_string(structure.levels) + ", needs at least 1");
    }
    if (level < 0 || level > structure.levels) {
        throw Error(structure_where(structure), "level " + std::to_string(level) + " outside 0.." +
                                                    std::to_string(structure.levels));
    }
}

// The geometry of Eq. 7 and 8 only makes sense for a fovea that fits in its outer box; a structure
// built by hand (not through the config parser) is checked here rather than giving boxes that are
// silently not nested.
void check_geometry(const FoveatedStructure& structure)
{
    const Eigen::Vector3f limit = structure.fovea_offset_limit();
    for (int axis = 0; axis < 3; ++axis) {
        const float outer_size = structure.outer_size[axis];
        const float fovea_size = structure.fovea_size[axis];
        const float offset = structure.fovea_offset[axis];
        if (!std::isfinite(structure.outer_min[axis]) || !std::isfinite(outer_size) ||
            !std::isfinite(fovea_size) || !std::isfinite(offset)) {
            throw Error(structure_where(structure),
                        std::string("non-finite geometry on ") + axis_name(axis));
        }
        if (!(outer_size > 0.0f) || !(fovea_size > 0.0f)) {
            throw Error(structure_where(structure),
                        std::string("box sizes must be positive, ") + axis_name(axis) +
                            " has outer " + std::to_string(outer_size) + ", fovea " +
                            std::to_string(fovea_size));
        }
        if (fovea_size > outer_size) {
            throw Error(structure_where(structure),
                        std::string("fovea bigger than the outer box on ") + axis_name(axis));
        }
        if (std::abs(offset) > limit[axis]) {
            throw Error(structure_where(structure),
                        std::string("fovea offset ") + axis_name(axis) + " = " +
                            std::to_string(offset) + " puts the fovea outside the outer box (limit ±" +
                            std::to_string(limit[axis]) + ")");
        }
    }
}

// d_k = d_0 + k (d_m - d_0) / m, in double so that k = 0 and k = m give d_0 and d_m exactly.
float interpolate(float outer, float fovea, int level, int levels)
{
    const double step = (double(fovea) - double(outer)) / double(levels);
    if (level == levels) return fovea;
    return static_cast<float>(double(outer) + double(level) * step);
}

}  // namespace

Box FoveatedStructure::level_box(int level) const
{
    check_level(*this, level);
    check_geometry(*this);
    if (level == 0) return outer_box();

    // Eq. 7 and 8 in double, rounded once to float. The min corner is Δ + δ_k; the max corner
    // Δ + δ_k + S_k is rewritten as (Δ + S_0) - k (S_0 - S_m - 2F) / (2m), the same value, so that
    // both corners move monotonically with k: rounding can then never push box k + 1 out of box k,
    // which the redundancy treatment and the index kernels rely on (a point in box k + 1 is in box
    // k). The float limit (S_0 - S_m)/2 can exceed the exact one by half an ulp, so the slack
    // 2F + S_0 - S_m is clamped to its exact range [0, 2 (S_0 - S_m)].
    const double k = level;
    const double m = levels;
    Box box;
    for (int axis = 0; axis < 3; ++axis) {
        const double outer_min_d = outer_min[axis];
        const double outer_size_d = outer_size[axis];
        const double spare = outer_size_d - double(fovea_size[axis]);  // S_0 - S_m >= 0
        const double before = std::clamp(spare + 2.0 * double(fovea_offset[axis]), 0.0, 2.0 * spare);
        const double after = 2.0 * spare - before;  // S_0 - S_m - 2F
        box.min[axis] = static_cast<float>(outer_min_d + k * before / (2.0 * m));
        box.max[axis] = static_cast<float>((outer_min_d + outer_size_d) - k * after / (2.0 * m));
    }
    return box;
}

float FoveatedStructure::density(int level) const
{
    check_level(*this, level);
    return interpolate(density_outer, density_fovea, level, levels);
}

float FoveatedStructure::keypoint_radius(int level) const
{
    check_level(*this, level);
    return interpolate(keypoint_radius_outer, keypoint_radius_fovea, level, levels);
}

int FoveatedStructure::level_of(const Eigen::Vector3f& p) const
{
    // Boxes are nested, so the first box (from the fovea outwards) that holds p is the largest k.
    for (int level = levels; level >= 0; --level) {
        if (level_box(level).contains(p)) return level;
    }
    return -1;
}

void FoveatedStructure::set_fovea_center(const Eigen::Vector3f& center)
{
    // F = (c - Δ) - S_0/2 in double, rounded once: the config parser converts "fovea_center" in the
    // same order, so a centre set here and one read from a config give the same F.
    for (int axis = 0; axis < 3; ++axis) {
        fovea_offset[axis] = static_cast<float>(double(center[axis]) - double(outer_min[axis]) -
                                                0.5 * double(outer_size[axis]));
    }
}

FoveatedStructure structure_between(const Box& outer, const Box& fovea, int levels, const LevelDetail& detail,
                                    std::string name)
{
    FoveatedStructure structure;
    structure.levels = levels;
    structure.outer_min = outer.min;
    structure.outer_size = outer.size();
    structure.fovea_size = fovea.size();
    structure.set_fovea_center(fovea.center());
    structure.density_outer = detail.density_outer;
    structure.density_fovea = detail.density_fovea;
    structure.keypoint_radius_outer = detail.keypoint_radius_outer;
    structure.keypoint_radius_fovea = detail.keypoint_radius_fovea;
    structure.name = std::move(name);
    return structure;
}

}  // namespace mfpc
