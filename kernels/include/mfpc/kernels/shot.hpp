#pragma once

/// @file
/// @brief SHOT352 descriptors (as PCL 1.13's SHOTEstimation) at keypoints.

#include <cstddef>
#include <span>

#include "mfpc/core/point_cloud.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/kernels/local_reference_frame.hpp"

namespace mfpc {

/// @brief The length of a SHOT352 descriptor.
///
/// SHOT352 (Salti, Tombari & Di Stefano 2014): 32 spatial volumes (8 azimuth x 2 elevation x 2
/// radial) x 11 slots of the cosine between the neighbour's normal and the frame's z axis (PCL's 10
/// cosine bins plus the slot its rounding adds), with interpolation between neighbouring bins,
/// normalised to unit length. Computed in SHOT's own local reference frame (weighted covariance of
/// the support, signs by majority), as PCL 1.13's SHOTEstimation does, to within a few 1e-7 (L2).
inline constexpr std::size_t shot_size = 352;

/// @brief Parameters of SHOT.
struct ShotParams {
    float radius = 0.02f;  ///< r_s: the support radius of the descriptor and of its frame.
};

/// @brief Descriptor of each keypoint over the points of `surface` within the radius (squared
/// distance < radius^2, as PCL's kd-tree) and their normals (surface_normals[i] belongs to
/// surface.points()[i]; points with a NaN normal are left out of the histogram, not of the frame).
///
/// Undefined results are all NaN, as PCL writes them: frame and descriptor when the keypoint is not
/// finite or has fewer than 5 neighbours besides itself (or a degenerate support); the descriptor
/// alone, the frame kept, when no neighbour has a normal. Parallel over keypoints; the output does
/// not depend on the number of threads.
/// @param keypoints The keypoints.
/// @param surface The grid over the points that make the descriptors.
/// @param surface_normals One normal per surface point.
/// @param params The support radius.
/// @param frames Receives SHOT's frame at each keypoint: frames[i] for keypoint i.
/// @param descriptors Receives shot_size values per keypoint: descriptors[i * shot_size ...] for
/// keypoint i.
/// @param support When given, holds the keypoints' neighbourhoods in `surface` (from
/// surface.radius_neighborhoods(keypoints, r), r >= the radius), read instead of searching: the
/// same descriptors, without a search per keypoint when BOARD shares them.
/// @return The number of keypoints whose frame or descriptor is undefined.
/// @throws mfpc::Error for a radius that is not positive and finite, spans of the wrong size
/// (normals vs surface, frames vs keypoints, descriptors vs 352 x keypoints), or a `support` of
/// other keypoints, of another surface or of too small a radius.
std::size_t shot_descriptors(std::span<const Point> keypoints, const NeighborGrid& surface,
                             std::span<const Point> surface_normals, const ShotParams& params,
                             std::span<LocalReferenceFrame> frames, std::span<float> descriptors,
                             const Neighborhoods* support = nullptr);

}  // namespace mfpc
