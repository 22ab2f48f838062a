#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "mfpc/core/point_cloud.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/index/organized_neighbors.hpp"
#include "mfpc/kernels/local_reference_frame.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

// The keypoints of a cloud with what matching and grouping need. Only keypoints whose BOARD frame
// and SHOT descriptor are both defined are kept; `invalid` counts the others.
struct Features {
    std::vector<Point> keypoints;
    std::vector<LocalReferenceFrame> frames;  // BOARD, r_l (Hough voting)
    std::vector<float> descriptors;           // shot_size per keypoint, SHOT352, r_s
    std::size_t candidates = 0;               // keypoints before dropping invalid ones
    std::size_t invalid = 0;
    std::size_t size() const { return keypoints.size(); }
    std::span<const float> descriptor(std::size_t i) const;
};

struct FeatureTimings {
    double normals_ms = 0;
    double keypoints_ms = 0;
    double lrf_ms = 0;
    double descriptors_ms = 0;
};

// Grid cell for the k-nearest queries of normal estimation: a few sensor spacings (about 2 mm on a
// Kinect view at 1-2 m), so the first shells of cells hold the k neighbours.
inline constexpr float normal_grid_cell = 0.005f;

// Neighbours (8 bytes each) that describe_keypoints holds at once in the keypoints' supports: 256
// MB. A Kinect scene at the default radii needs 2 million; more come in batches (see below).
inline constexpr std::size_t default_support_budget = std::size_t(1) << 25;

// Normals, BOARD frames and SHOT descriptors at `keypoints` (indices into surface) over the search
// surface `surface`. Normals are estimated only for the surface points inside some keypoint's
// support, from their `normal_k` nearest neighbours in `normal_source`: a grid over the surface
// itself, or over a denser cloud that holds the same geometry (cell normal_grid_cell); or, when
// that cloud is organized, its depth image (the same normals, faster).
// Estimated normals face the sensor at the origin, which is right for a view from a sensor. A
// model sampled all around an object has no such viewpoint: its own normals (`orientation`, one
// per surface point, e.g. a mesh's outward normals) then say which way each estimated normal
// points; non-finite ones leave the sensor's choice.
// Keypoints whose supports would hold more than `support_budget` neighbours together are described
// in batches that each hold at most that many (or one keypoint), with the same result: memory
// stays bounded for a tiny keypoint radius or supports as wide as the scene.
Features describe_keypoints(std::span<const Point> surface, std::span<const std::uint32_t> keypoints,
                            const NeighborGrid& normal_source, const FeatureParams& params,
                            FeatureTimings* timings = nullptr, std::span<const Point> orientation = {},
                            std::size_t support_budget = default_support_budget);
Features describe_keypoints(std::span<const Point> surface, std::span<const std::uint32_t> keypoints,
                            const OrganizedNeighbors& normal_source, const FeatureParams& params,
                            FeatureTimings* timings = nullptr, std::span<const Point> orientation = {},
                            std::size_t support_budget = default_support_budget);

/// @brief Describes a cloud at the working resolution params.resolution (> 0): the cloud is
/// resampled to one point per voxel (voxel_grid), and normals (its normal_k nearest resampled
/// points, facing the sensor at the origin), keypoints (uniform sampling at keypoint_radius), BOARD
/// frames and SHOT descriptors are all taken on the resampled surface. `orientation`, one normal
/// per cloud point or empty, orients the normals as in describe_keypoints (each voxel takes its
/// lowest-index point's). Time spent resampling and sampling keypoints counts as normals.
/// `resampled_points`, when given, receives the number of voxels described.
/// @throws mfpc::Error when params.resolution is not positive, or as voxel_grid and describe_keypoints.
Features describe_at_resolution(std::span<const Point> cloud, const FeatureParams& params,
                                FeatureTimings* timings = nullptr, std::span<const Point> orientation = {},
                                std::size_t* resampled_points = nullptr);

}  // namespace mfpc
