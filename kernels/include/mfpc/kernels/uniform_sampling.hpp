#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "mfpc/core/foveated_structure.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

// Keypoints by uniform sampling (PCL's UniformSampling): the cloud is cut into cubes of edge
// `radius` anchored at the origin, cube (i, j, k) = floor(p * (1 / radius)) in float, and each
// occupied cube keeps the point nearest its centre (ties: the lowest index). Returns the indices
// of the kept points, ascending. The distance is computed as PCL 1.13 computes it (see the
// source), so the selected set is identical to PCL's, ties included.
std::vector<std::uint32_t> uniform_sampling(std::span<const Point> points, float radius);

// Uniform sampling of a foveated cloud: each region (structure, level) is sampled on its own with
// its keypoint radius r_k (paper Section 5.4). Points labelled (-1, -1), outside every structure,
// are sampled with `unlabelled_radius` (0: they get no keypoints). Indices ascending.
std::vector<std::uint32_t> uniform_sampling(std::span<const Point> points, std::span<const RegionLabel> labels,
                                            std::span<const FoveatedStructure> structures,
                                            float unlabelled_radius = 0.0f);

}  // namespace mfpc
