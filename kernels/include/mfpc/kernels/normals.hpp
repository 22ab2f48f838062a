#pragma once

/// @file
/// @brief Surface normals by PCA of the k nearest neighbours (as PCL's NormalEstimation), and their
/// orientation by reference normals.

#include <span>

#include "mfpc/core/point_cloud.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/index/organized_neighbors.hpp"

namespace mfpc {

/// @brief Parameters of normal estimation.
struct NormalParams {
    int k = 10;                                  ///< k_n: neighbours of the PCA, the point itself included.
    Point viewpoint = Point::Zero();             ///< Normals are flipped to face it (the sensor).
};

/// @brief Surface normal at each query point: the eigenvector of the smallest eigenvalue of the
/// covariance of its k nearest neighbours in `surface`, flipped so that (viewpoint - q) . n >= 0,
/// as PCL's NormalEstimation.
///
/// A normal that cannot be defined (fewer than 3 neighbours, or a degenerate neighbourhood: all at
/// one spot or on one line, the middle eigenvalue below 1e-7 of the largest) is NaN, and later
/// stages skip it.
/// @param queries The points to estimate normals at.
/// @param surface The grid over the points whose neighbours are taken.
/// @param params k and the viewpoint.
/// @param normals Receives one normal per query: normals.size() must equal queries.size().
/// @throws mfpc::Error when normals.size() is not queries.size(), for k below 3, a viewpoint that
/// is not finite, or a query that is not finite.
void estimate_normals(std::span<const Point> queries, const NeighborGrid& surface, const NormalParams& params,
                      std::span<Point> normals);
/// @brief The same over an organized cloud (a sensor's depth image), with the same results, faster.
/// @param queries The points to estimate normals at.
/// @param surface The depth-image search over the points whose neighbours are taken.
/// @param params k and the viewpoint.
/// @param normals Receives one normal per query: normals.size() must equal queries.size().
/// @throws mfpc::Error as estimate_normals over a NeighborGrid.
void estimate_normals(std::span<const Point> queries, const OrganizedNeighbors& surface, const NormalParams& params,
                      std::span<Point> normals);

/// @brief Flips each normal whose dot product with its reference normal is negative (a closed
/// model has no viewpoint to face; its own outward normals orient the estimated ones). A
/// non-finite reference leaves its normal alone.
/// @param normals The normals to orient, in place.
/// @param reference One reference normal per normal.
/// @throws mfpc::Error when the spans differ in size.
void orient_normals(std::span<Point> normals, std::span<const Point> reference);

}  // namespace mfpc
