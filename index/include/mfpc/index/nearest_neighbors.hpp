#pragma once

/// @file
/// @brief The sampling spacing of a cloud (exact nearest-neighbour distances, FLANN).

#include <span>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

/// @brief The mean distance from each point to its nearest other point (FLANN kd-tree, exact
/// search): the cloud's sampling spacing.
///
/// Summed in fixed blocks reduced in order, so the result is the same at any thread count.
/// @param points The cloud.
/// @return The mean spacing; 0 for clouds of fewer than two points. Exact duplicates count as
/// distance 0 (and are searched once, so they cost linear time).
/// @throws mfpc::Error for a point not finite or beyond ±max_coordinate.
double mean_spacing(std::span<const Point> points);

}  // namespace mfpc
