#include "mfpc/kernels/uniform_sampling.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "voxel_slots.hpp"

namespace mfpc {
namespace {

constexpr int axis_bits = 21;

void check_radius(float radius, const char* what)
{
    if (!(radius > 0.0f) || !std::isfinite(radius))
        throw Error("uniform_sampling", std::string(what) + " must be a positive number, got " + format_number(radius));
}

// PCL 1.13 compares the squared distances of 4-vectors (x, y, z, 1) - (cx, cy, cz, 0), reduced by
// Eigen's SSE code as (dx^2 + dz^2) + (dy^2 + 1). The +1 rounds away the low bits of the distance,
// which decides near-ties; computing it the same way keeps the selected set identical to PCL's.
inline float pcl_distance(const Point& p, const Eigen::Vector3f& center)
{
    const float dx = p.x() - center.x();
    const float dy = p.y() - center.y();
    const float dz = p.z() - center.z();
    return (dx * dx + dz * dz) + (dy * dy + 1.0f);
}

// Samples points[members] (ascending indices) with one radius, appending the kept indices.
void sample_group(std::span<const Point> points, std::span<const std::uint32_t> members, float radius,
                  std::vector<std::uint32_t>& kept)
{
    if (members.empty()) return;
    const float inverse = 1.0f / radius;
    std::vector<Eigen::Vector3i> cells(members.size());
    // A cube number beyond int is undefined on conversion (and NaN has none): such points are
    // found first and named, so that every cube number below fits, as do their differences.
    constexpr float reach = float(1 << 30);
    auto in_reach = [&](const Point& p) {
        return std::abs(p.x() * inverse) < reach && std::abs(p.y() * inverse) < reach &&
               std::abs(p.z() * inverse) < reach;
    };
    std::atomic<bool> beyond{false};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, members.size(), 4096), [&](const auto& range) {
        for (std::size_t i = range.begin(); i < range.end(); ++i) {
            const Point& p = points[members[i]];
            if (!in_reach(p)) {
                beyond = true;
                continue;
            }
            cells[i] = Eigen::Vector3i(int(std::floor(p.x() * inverse)), int(std::floor(p.y() * inverse)),
                                       int(std::floor(p.z() * inverse)));
        }
    });
    if (beyond) {
        const auto far =
            std::find_if(members.begin(), members.end(), [&](std::uint32_t m) { return !in_reach(points[m]); });
        throw Error("uniform_sampling", "point " + std::to_string(*far) + " is not finite or lies more than 2^30 " +
                                            "cubes of " + format_number(radius) + " m from the origin");
    }
    Eigen::Vector3i lo = cells[0];
    Eigen::Vector3i hi = cells[0];
    for (const auto& c : cells) {
        lo = lo.cwiseMin(c);
        hi = hi.cwiseMax(c);
    }
    // The cube table takes 21 bits of cube number per axis. A cloud that spans more (a stray point
    // kilometres away) is numbered by rank among its occupied cube numbers on that axis instead:
    // the same cubes, in the same order, so the same points are kept.
    std::vector<Eigen::Vector3i> ranked;
    if ((hi - lo).maxCoeff() >= (1 << axis_bits)) {
        ranked = cells;
        for (int axis = 0; axis < 3; ++axis) {
            std::vector<int> occupied(cells.size());
            for (std::size_t i = 0; i < cells.size(); ++i) occupied[i] = cells[i][axis];
            std::sort(occupied.begin(), occupied.end());
            occupied.erase(std::unique(occupied.begin(), occupied.end()), occupied.end());
            if (occupied.size() > (std::size_t(1) << axis_bits))
                throw Error("uniform_sampling", "the points occupy more than 2^21 cubes of " + format_number(radius) +
                                                    " m along one axis; use a larger radius");
            for (auto& c : ranked)
                c[axis] = int(std::lower_bound(occupied.begin(), occupied.end(), c[axis]) - occupied.begin());
            lo[axis] = 0;
            hi[axis] = int(occupied.size()) - 1;
        }
    }
    const std::vector<Eigen::Vector3i>& numbered = ranked.empty() ? cells : ranked;
    // One pass in ascending index order (the order PCL visits a cube's points in), keeping per cube
    // the point nearest its centre, the first of equals: the cubes numbered as met, not a sort of
    // the points.
    struct Cube {
        std::uint32_t best = 0;
        float distance = 0.0f;
    };
    std::vector<Cube> cubes;
    detail::VoxelSlots slots((hi - lo).cast<std::int64_t>().array() + 1, members.size());
    for (std::size_t i = 0; i < members.size(); ++i) {
        const Eigen::Vector3i d = numbered[i] - lo;
        // PCL: (ijk + 0.5) * radius in float.
        const Eigen::Vector3f center = (cells[i].cast<float>().array() + 0.5f) * radius;
        const std::uint32_t point = members[i];
        const float distance = pcl_distance(points[point], center);
        const auto [slot, is_new] = slots.find(d.x(), d.y(), d.z(), std::uint32_t(cubes.size()));
        if (is_new) {
            cubes.push_back(Cube{point, distance});
        } else if (distance < cubes[slot].distance) {
            cubes[slot] = Cube{point, distance};
        }
    }
    for (const Cube& cube : cubes) kept.push_back(cube.best);
}

}  // namespace

std::vector<std::uint32_t> uniform_sampling(std::span<const Point> points, float radius)
{
    check_radius(radius, "the radius");
    std::vector<std::uint32_t> members(points.size());
    for (std::size_t i = 0; i < members.size(); ++i) members[i] = std::uint32_t(i);
    std::vector<std::uint32_t> kept;
    sample_group(points, members, radius, kept);
    std::sort(kept.begin(), kept.end());
    return kept;
}

std::vector<std::uint32_t> uniform_sampling(std::span<const Point> points, std::span<const RegionLabel> labels,
                                            std::span<const FoveatedStructure> structures, float unlabelled_radius)
{
    if (labels.size() != points.size())
        throw Error("uniform_sampling", std::to_string(labels.size()) + " labels for " +
                                            std::to_string(points.size()) + " points");
    if (unlabelled_radius != 0.0f) check_radius(unlabelled_radius, "the radius outside the structures");
    // Group points by region: group 0 holds the unlabelled points, group 1 + r region r.
    int levels = structures.empty() ? 0 : structures.front().levels;
    for (const auto& s : structures) levels = std::max(levels, s.levels);
    const std::size_t groups = 1 + structures.size() * std::size_t(levels + 1);
    std::vector<std::vector<std::uint32_t>> members(groups);
    for (std::size_t i = 0; i < points.size(); ++i) {
        const RegionLabel label = labels[i];
        std::size_t group = 0;
        if (label.structure >= 0) {
            if (std::size_t(label.structure) >= structures.size() || label.level < 0 ||
                label.level > structures[std::size_t(label.structure)].levels)
                throw Error("uniform_sampling", "point " + std::to_string(i) + " is labelled with structure " +
                                                    std::to_string(label.structure) + " level " +
                                                    std::to_string(label.level) + ", which does not exist");
            group = 1 + std::size_t(label.structure) * std::size_t(levels + 1) + std::size_t(label.level);
        }
        members[group].push_back(std::uint32_t(i));
    }
    std::vector<std::uint32_t> kept;
    if (unlabelled_radius > 0.0f) sample_group(points, members[0], unlabelled_radius, kept);
    for (std::size_t s = 0; s < structures.size(); ++s) {
        for (int level = 0; level <= structures[s].levels; ++level) {
            const float radius = structures[s].keypoint_radius(level);
            const auto& group = members[1 + s * std::size_t(levels + 1) + std::size_t(level)];
            if (group.empty()) continue;
            check_radius(radius, "a keypoint radius");
            sample_group(points, group, radius, kept);
        }
    }
    std::sort(kept.begin(), kept.end());
    return kept;
}

}  // namespace mfpc
