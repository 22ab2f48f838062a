#pragma once

#include <span>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

// The mean distance from each point to its nearest other point (FLANN kd-tree, exact search):
// the cloud's sampling spacing. 0 for clouds of fewer than two points. Exact duplicates count
// as distance 0.
double mean_spacing(std::span<const Point> points);

}  // namespace mfpc
