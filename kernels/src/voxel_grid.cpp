#include "mfpc/kernels/voxel_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "mfpc/core/error.hpp"

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
    // Cells relative to the lowest one, 21 bits an axis, so a key is one integer to sort by; a
    // cloud wider than 2^21 voxels on an axis is keyed by the cells' rank instead.
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
    const Eigen::Vector3i span = high - low;
    const bool packed = (span.array() < (1 << 21)).all();

    std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(points.size());
    if (packed) {
        tbb::parallel_for(std::size_t(0), points.size(), [&](std::size_t i) {
            const Eigen::Vector3i c = cells[i] - low;
            keyed[i] = {(std::uint64_t(c.x()) << 42) | (std::uint64_t(c.y()) << 21) | std::uint64_t(c.z()),
                        std::uint32_t(i)};
        });
        tbb::parallel_sort(keyed.begin(), keyed.end());
    } else {
        // Sort by the cell itself, then key each point by its cell's rank.
        std::vector<std::uint32_t> order(points.size());
        for (std::size_t i = 0; i < order.size(); ++i) order[i] = std::uint32_t(i);
        auto less = [&](std::uint32_t a, std::uint32_t b) {
            const Eigen::Vector3i &p = cells[a], &q = cells[b];
            if (p.x() != q.x()) return p.x() < q.x();
            if (p.y() != q.y()) return p.y() < q.y();
            if (p.z() != q.z()) return p.z() < q.z();
            return a < b;
        };
        tbb::parallel_sort(order.begin(), order.end(), less);
        std::uint64_t rank = 0;
        for (std::size_t i = 0; i < order.size(); ++i) {
            if (i > 0 && cells[order[i]] != cells[order[i - 1]]) ++rank;
            keyed[i] = {rank, order[i]};
        }
    }

    // Runs of one key are one voxel, their points in index order.
    std::vector<std::pair<std::uint32_t, std::size_t>> voxels;  // (lowest index, where its run starts)
    for (std::size_t i = 0; i < keyed.size(); ++i)
        if (i == 0 || keyed[i].first != keyed[i - 1].first) voxels.push_back({keyed[i].second, i});
    std::vector<std::size_t> run_end(voxels.size());
    for (std::size_t v = 0; v < voxels.size(); ++v)
        run_end[v] = v + 1 < voxels.size() ? voxels[v + 1].second : keyed.size();
    std::vector<Point> centroids(voxels.size());
    tbb::parallel_for(std::size_t(0), voxels.size(), [&](std::size_t v) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (std::size_t i = voxels[v].second; i < run_end[v]; ++i) sum += points[keyed[i].second].cast<double>();
        centroids[v] = (sum / double(run_end[v] - voxels[v].second)).cast<float>();
    });
    std::vector<std::uint32_t> order(voxels.size());
    for (std::size_t v = 0; v < order.size(); ++v) order[v] = std::uint32_t(v);
    tbb::parallel_sort(order.begin(), order.end(),
                       [&](std::uint32_t a, std::uint32_t b) { return voxels[a].first < voxels[b].first; });
    grid.centroids.resize(voxels.size());
    grid.first.resize(voxels.size());
    for (std::size_t v = 0; v < order.size(); ++v) {
        grid.centroids[v] = centroids[order[v]];
        grid.first[v] = voxels[order[v]].first;
    }
    return grid;
}

}  // namespace mfpc
