#pragma once

/// @file
/// @brief Voxel-grid resampling of a cloud to one point per occupied voxel (the working
/// resolution).

#include <cstdint>
#include <span>
#include <vector>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

/// @brief A cloud resampled to one point per occupied voxel.
struct VoxelGrid {
    std::vector<Point> centroids;        ///< per voxel: the mean of its points
    std::vector<std::uint32_t> first;    ///< per voxel: its lowest point index (a representative)
};

/// @brief Resamples `points` at the working resolution: the cloud is cut into cubes of edge
/// `voxel` anchored at the origin and each occupied cube gives the centroid of its points
/// (summed in index order, so the result is the same at any thread count). Voxels come in the
/// order of their lowest point index, so an organized cloud keeps its image order.
///
/// What a sensor's sampling leaves in a cloud (points per area growing with 1/z² and with the
/// focal length, terraces of quantized depth) is gone at a resolution coarser than the sensor's
/// pixel footprint: the result has one point per voxel of surface, whatever the sensor or distance.
/// @param points The cloud.
/// @param voxel The voxel edge (metres).
/// @return The centroid and the lowest point index of each occupied voxel.
/// @throws mfpc::Error for a voxel that is not positive and finite, a point that is not finite,
/// a point more than 2^30 voxels from the origin, or more points than 32-bit indices can number.
VoxelGrid voxel_grid(std::span<const Point> points, float voxel);

}  // namespace mfpc
