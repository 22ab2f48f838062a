#include "mfpc/kernels/voxel_grid.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <utility>

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "mfpc/core/error.hpp"
#include "mfpc/index/detail/radix_sort.hpp"

namespace mfpc {

VoxelGrid voxel_grid(std::span<const Point> points, float voxel)
{
    if (!(voxel > 0.0f) || !std::isfinite(voxel))
        throw Error("voxel_grid", "the voxel must be positive and finite, not " + format_number(voxel));
    VoxelGrid grid;
    if (points.empty()) return grid;
    if (points.size() > std::numeric_limits<std::uint32_t>::max())
        throw Error("voxel_grid", "more points than 32-bit indices can number");

    for (const Point& p : points)
        if (!p.allFinite()) throw Error("voxel_grid", "a point is not finite");
    const double inverse = 1.0 / double(voxel);
    constexpr double limit = double(1 << 30);
    std::vector<Eigen::Vector3i> cells(points.size());
    tbb::parallel_for(std::size_t(0), points.size(), [&](std::size_t i) {
        const Eigen::Vector3d c = (points[i].cast<double>() * inverse).array().floor();
        cells[i] = Eigen::Vector3i(int(std::clamp(c.x(), -limit, limit)), int(std::clamp(c.y(), -limit, limit)),
                                   int(std::clamp(c.z(), -limit, limit)));
    });
    Eigen::Vector3i low = cells[0], high = cells[0];
    for (const Eigen::Vector3i& c : cells) {
        low = low.cwiseMin(c);
        high = high.cwiseMax(c);
    }
    if ((low.array() <= -int(limit)).any() || (high.array() >= int(limit)).any())
        throw Error("voxel_grid", "a point lies more than 2^30 voxels of " + format_number(voxel) + " m from the origin");
    // Cells numbered x-major from the lowest one, so a number is one integer to sort by; a cloud
    // whose extent in voxels has more cells than 64 bits number is keyed by the cells' rank instead.
    const Eigen::Vector3i span = high - low;
    const std::uint64_t nx = std::uint64_t(span.x()) + 1, ny = std::uint64_t(span.y()) + 1,
                        nz = std::uint64_t(span.z()) + 1;  // each at most 2^31, so nx * ny fits
    std::vector<std::uint32_t> order;  // point indices by cell, ascending within a cell
    std::vector<std::uint64_t> keys;   // their cells' numbers
    if (nx * ny <= std::numeric_limits<std::uint64_t>::max() / nz) {
        const int bits = int(std::bit_width(nx * ny * nz - 1));
        detail::sort_by_key(
            points.size(), bits,
            [&](std::size_t i) {
                const Eigen::Vector3i c = cells[i] - low;
                return (std::uint64_t(c.x()) * ny + std::uint64_t(c.y())) * nz + std::uint64_t(c.z());
            },
            order, keys);
    } else {
        order.resize(points.size());
        for (std::size_t i = 0; i < order.size(); ++i) order[i] = std::uint32_t(i);
        auto less = [&](std::uint32_t a, std::uint32_t b) {
            const Eigen::Vector3i &p = cells[a], &q = cells[b];
            if (p.x() != q.x()) return p.x() < q.x();
            if (p.y() != q.y()) return p.y() < q.y();
            if (p.z() != q.z()) return p.z() < q.z();
            return a < b;
        };
        tbb::parallel_sort(order.begin(), order.end(), less);
        keys.assign(points.size(), 0);
        for (std::size_t i = 1; i < order.size(); ++i)
            keys[i] = keys[i - 1] + (cells[order[i]] != cells[order[i - 1]] ? 1 : 0);
    }

    // Runs of one key are one voxel, their points in index order (the sort is stable), so a run's
    // first entry is its voxel's lowest index. Voxels are then taken in that order by one pass over
    // the points, marking where each voxel's lowest point is.
    constexpr std::uint32_t no_run = std::numeric_limits<std::uint32_t>::max();
    std::vector<std::uint32_t> run_begin;
    for (std::size_t i = 0; i < keys.size(); ++i)
        if (i == 0 || keys[i] != keys[i - 1]) run_begin.push_back(std::uint32_t(i));
    run_begin.push_back(std::uint32_t(keys.size()));
    std::vector<std::uint32_t> run_at(points.size(), no_run);
    for (std::uint32_t r = 0; r + 1 < run_begin.size(); ++r) run_at[order[run_begin[r]]] = r;
    std::vector<std::uint32_t> runs;  // in the order of their lowest index
    runs.reserve(run_begin.size() - 1);
    for (const std::uint32_t r : run_at)
        if (r != no_run) runs.push_back(r);
    grid.centroids.resize(runs.size());
    grid.first.resize(runs.size());
    tbb::parallel_for(std::size_t(0), runs.size(), [&](std::size_t v) {
        const std::uint32_t begin = run_begin[runs[v]], end = run_begin[runs[v] + 1];
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (std::uint32_t i = begin; i < end; ++i) sum += points[order[i]].cast<double>();
        grid.centroids[v] = (sum / double(end - begin)).cast<float>();
        grid.first[v] = order[begin];
    });
    return grid;
}

}  // namespace mfpc
