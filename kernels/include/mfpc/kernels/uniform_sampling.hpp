#pragma once

/// @file
/// @brief Keypoints by uniform sampling (as PCL's UniformSampling), of a whole cloud or of a
/// foveated cloud region by region.

#include <cstdint>
#include <span>
#include <vector>

#include "mfpc/core/foveated_structure.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

/// @brief Keypoints by uniform sampling (PCL's UniformSampling): the cloud is cut into cubes of
/// edge `radius` anchored at the origin, cube (i, j, k) = floor(p * (1 / radius)) in float, and
/// each occupied cube keeps the point nearest its centre (ties: the lowest index).
///
/// The distance is computed as PCL 1.13 computes it (see the source), so the selected set is
/// identical to PCL's, ties included.
/// @param points The cloud.
/// @param radius The cube edge (metres).
/// @return The indices of the kept points, ascending.
/// @throws mfpc::Error for a radius that is not positive and finite, a point that is not finite or
/// lies more than 2^30 cubes from the origin, or points that occupy more than 2^21 cubes along one
/// axis.
std::vector<std::uint32_t> uniform_sampling(std::span<const Point> points, float radius);

/// @brief Uniform sampling of a foveated cloud: each region (structure, level) is sampled on its
/// own with its keypoint radius r_k (paper Section 5.4).
/// @param points The foveated cloud's points.
/// @param labels The region label of each point.
/// @param structures The structures the labels refer to, which give each level's keypoint radius.
/// @param unlabelled_radius The radius for points labelled (-1, -1), outside every structure (0:
/// they get no keypoints).
/// @return The indices of the kept points, ascending.
/// @throws mfpc::Error when there is not one label per point, a label names a structure or level
/// that does not exist, `unlabelled_radius` is neither 0 nor positive and finite, an occupied
/// region's keypoint radius is not positive and finite, or as uniform_sampling(points, radius).
std::vector<std::uint32_t> uniform_sampling(std::span<const Point> points, std::span<const RegionLabel> labels,
                                            std::span<const FoveatedStructure> structures,
                                            float unlabelled_radius = 0.0f);

}  // namespace mfpc
