#pragma once

/// @file
/// @brief Correspondence grouping into object hypotheses: Hough 3D voting and geometric
/// consistency, and the rigid fit they pose instances with.

#include <vector>

#include "mfpc/core/pose.hpp"
#include "mfpc/recognition/features.hpp"
#include "mfpc/recognition/matching.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

/// @brief One object hypothesis: the pose mapping model into scene and the correspondences behind
/// it.
struct Instance {
    Pose transform = Pose::Identity();            ///< Maps model coordinates into scene coordinates.
    /// Hough: interpolated votes of the maximum (scaled for a further pose); GC: cluster size.
    float votes = 0.0f;
    std::vector<Correspondence> correspondences;  ///< The consistent ones (pose fit inliers).
    float fitness = 0.0f;                        ///< After verification: inlier fraction (0 when not verified).
    float coverage = 0.0f;                      ///< Inlier model points / model points facing the camera.
    /// Fraction of projected model points lying in observed free space (see refine_and_verify).
    float free_space_violation = 0.0f;
    float thickness_ratio = 0.0f;                ///< Fitting points' spread off their best plane / the facing side's.
    /// Of the rim probes settled either way, the fraction the scene goes on at.
    float continuation = 0.0f;
    float rmse = 0.0f;                           ///< Of the refined fit (metres).
};

/// @brief Hough 3D voting (Tombari & Di Stefano 2010).
///
/// Each correspondence casts a vote for the model's reference point (the centroid of the model
/// keypoints), carried into the scene through the two BOARD frames; votes are interpolated over the
/// 8 nearest bins of size hough_bin; every local maximum with at least hough_threshold votes is an
/// instance, posed by RANSAC + least squares (Umeyama) on its voters. A nearly symmetric object
/// draws votes at one place from several poses, so up to ransac_modes poses are fitted per maximum:
/// each further one by RANSAC on the voters no earlier pose took, kept when it has at least
/// mode_inlier_ratio of the first pose's inliers and is turned at least mode_min_angle from the
/// others, with the maximum's votes scaled by that ratio. Deterministic.
/// @param model The model's features.
/// @param scene The scene's features.
/// @param correspondences Model-scene keypoint pairs, numbering the two features' keypoints.
/// @param params hough_bin, hough_threshold, the RANSAC pose fit and its modes.
/// @return The instances, sorted by votes (descending; a maximum's poses in the order found among
/// equal votes); none without correspondences.
/// @throws mfpc::Error for a correspondence beyond the model's or the scene's keypoints, or a
/// hough_bin that is not positive.
std::vector<Instance> hough_grouping(const Features& model, const Features& scene,
                                     const std::vector<Correspondence>& correspondences, const GroupingParams& params);

/// @brief Geometric consistency grouping (as PCL's GeometricConsistencyGrouping): greedy clusters
/// of correspondences whose pairwise model and scene distances agree within gc_size.
/// @param model The model's features.
/// @param scene The scene's features.
/// @param correspondences Model-scene keypoint pairs, numbering the two features' keypoints.
/// @param params gc_size, gc_threshold (the smallest cluster) and the RANSAC pose fit.
/// @return The instances, one per cluster of at least gc_threshold correspondences that could be
/// posed, sorted by cluster size (descending).
/// @throws mfpc::Error for a correspondence beyond the model's or the scene's keypoints, or a
/// gc_size that is not positive.
std::vector<Instance> gc_grouping(const Features& model, const Features& scene,
                                  const std::vector<Correspondence>& correspondences, const GroupingParams& params);

/// @brief Least-squares rigid transform mapping `from` onto `to` (Umeyama, no scale).
/// @param from The points to move.
/// @param to Their targets, one per point of `from`.
/// @return The rigid transform.
/// @throws mfpc::Error unless there are at least three pairs (and as many targets as points).
Pose fit_rigid(std::span<const Point> from, std::span<const Point> to);

}  // namespace mfpc
