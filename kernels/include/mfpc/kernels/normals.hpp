#pragma once

#include <span>

#include "mfpc/core/point_cloud.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/index/organized_neighbors.hpp"

namespace mfpc {

struct NormalParams {
    int k = 10;                                  // k_n: neighbours of the PCA, the point itself included
    Point viewpoint = Point::Zero();             // normals are flipped to face it (the sensor)
};

// Surface normal at each query point: the eigenvector of the smallest eigenvalue of the covariance
// of its k nearest neighbours in `surface`, flipped so that (viewpoint - q) . n >= 0, as PCL's
// NormalEstimation. A normal that cannot be defined (fewer than 3 neighbours, or a degenerate
// neighbourhood: all at one spot or on one line, the middle eigenvalue below 1e-7 of the largest)
// is NaN, and later stages skip it. normals.size() must equal queries.size().
void estimate_normals(std::span<const Point> queries, const NeighborGrid& surface, const NormalParams& params,
                      std::span<Point> normals);
// The same over an organized cloud (a sensor's depth image), with the same results, faster.
void estimate_normals(std::span<const Point> queries, const OrganizedNeighbors& surface, const NormalParams& params,
                      std::span<Point> normals);

// Flips each normal whose dot product with its reference normal is negative (a closed model has no
// viewpoint to face; its own outward normals orient the estimated ones). A non-finite reference
// leaves its normal alone. Both spans have one entry per point.
void orient_normals(std::span<Point> normals, std::span<const Point> reference);

}  // namespace mfpc
