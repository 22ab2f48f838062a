#pragma once

/// @file
/// @brief Keypoint description for recognition: normals, BOARD frames and SHOT352 descriptors at
/// keypoints, directly or at a working resolution.

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

/// @brief The keypoints of a cloud with what matching and grouping need. Only keypoints whose BOARD
/// frame and SHOT descriptor are both defined are kept; `invalid` counts the others.
struct Features {
    std::vector<Point> keypoints;             ///< The kept keypoints.
    std::vector<LocalReferenceFrame> frames;  ///< BOARD, r_l (Hough voting).
    std::vector<float> descriptors;           ///< shot_size per keypoint, SHOT352, r_s.
    std::size_t candidates = 0;               ///< Keypoints before dropping invalid ones.
    std::size_t invalid = 0;                  ///< Keypoints dropped: no defined frame or descriptor.
    /// @brief The number of kept keypoints.
    /// @return keypoints.size().
    std::size_t size() const { return keypoints.size(); }
    /// @brief The descriptor of keypoint i.
    /// @param i A keypoint, below size().
    /// @return Its shot_size values.
    std::span<const float> descriptor(std::size_t i) const;
};

/// @brief Wall-clock milliseconds of the description steps, added to by the functions given them.
struct FeatureTimings {
    double normals_ms = 0;      ///< Normal estimation (and, at a working resolution, resampling and keypoint sampling).
    double keypoints_ms = 0;    ///< Keypoint sampling, where the caller times it (the functions here do not add to it).
    double lrf_ms = 0;          ///< BOARD frames.
    double descriptors_ms = 0;  ///< SHOT descriptors.
};

/// Grid cell for the k-nearest queries of normal estimation: a few sensor spacings (about 2 mm on a
/// Kinect view at 1-2 m), so the first shells of cells hold the k neighbours.
inline constexpr float normal_grid_cell = 0.005f;

/// Neighbours (8 bytes each) that describe_keypoints holds at once in the keypoints' supports: 256
/// MB. A Kinect scene at the default radii needs 2 million; more come in batches (see
/// describe_keypoints).
inline constexpr std::size_t default_support_budget = std::size_t(1) << 25;

/// @brief Normals, BOARD frames and SHOT descriptors at `keypoints` (indices into surface) over the
/// search surface `surface`.
///
/// Normals are estimated only for the surface points inside some keypoint's support, from their
/// `normal_k` nearest neighbours in `normal_source`: a grid over the surface itself, or over a
/// denser cloud that holds the same geometry (cell normal_grid_cell); or, when that cloud is
/// organized, its depth image (the same normals, faster, with the other overload).
///
/// Estimated normals face the sensor at the origin, which is right for a view from a sensor. A
/// model sampled all around an object has no such viewpoint: its own normals (`orientation`, one
/// per surface point, e.g. a mesh's outward normals) then say which way each estimated normal
/// points; non-finite ones leave the sensor's choice.
///
/// Keypoints whose supports would hold more than `support_budget` neighbours together are described
/// in batches that each hold at most that many (or one keypoint), with the same result: memory
/// stays bounded for a tiny keypoint radius or supports as wide as the scene.
/// @param surface The search surface.
/// @param keypoints The keypoints, as indices into `surface`.
/// @param normal_source Where the normals' neighbours are found.
/// @param params normal_k, lrf_radius and shot_radius.
/// @param timings When given, the time of each step is added to it.
/// @param orientation Empty, or one normal per surface point that orients the estimated ones.
/// @param support_budget The most neighbours held at once in the keypoints' supports.
/// @return The keypoints whose frame and descriptor are both defined, with them.
/// @throws mfpc::Error when `orientation` is neither empty nor one per surface point, the LRF or
/// SHOT radius is not positive, a keypoint index lies outside the surface, or as
/// estimate_normals, board_frames and shot_descriptors.
Features describe_keypoints(std::span<const Point> surface, std::span<const std::uint32_t> keypoints,
                            const NeighborGrid& normal_source, const FeatureParams& params,
                            FeatureTimings* timings = nullptr, std::span<const Point> orientation = {},
                            std::size_t support_budget = default_support_budget);
/// @brief describe_keypoints with the normals' neighbours found in the depth image of an organized
/// cloud (the same normals as over a grid, faster).
/// @param surface The search surface.
/// @param keypoints The keypoints, as indices into `surface`.
/// @param normal_source The depth-image search where the normals' neighbours are found.
/// @param params normal_k, lrf_radius and shot_radius.
/// @param timings When given, the time of each step is added to it.
/// @param orientation Empty, or one normal per surface point that orients the estimated ones.
/// @param support_budget The most neighbours held at once in the keypoints' supports.
/// @return The keypoints whose frame and descriptor are both defined, with them.
/// @throws mfpc::Error as describe_keypoints over a NeighborGrid.
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
/// @param cloud The cloud.
/// @param params The working resolution and the description parameters.
/// @param timings When given, the time of each step is added to it.
/// @param orientation Empty, or one normal per cloud point.
/// @param resampled_points When given, receives the number of voxels described.
/// @return The described keypoints of the resampled surface.
/// @throws mfpc::Error when params.resolution is not positive, `orientation` is neither empty nor
/// one per cloud point, or as voxel_grid, uniform_sampling and describe_keypoints.
Features describe_at_resolution(std::span<const Point> cloud, const FeatureParams& params,
                                FeatureTimings* timings = nullptr, std::span<const Point> orientation = {},
                                std::size_t* resampled_points = nullptr);

}  // namespace mfpc
