#pragma once

#include <vector>

#include "mfpc/core/pose.hpp"
#include "mfpc/recognition/features.hpp"
#include "mfpc/recognition/matching.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

// One object hypothesis: the pose mapping model into scene and the correspondences behind it.
struct Instance {
    Pose transform = Pose::Identity();
    float votes = 0.0f;                          // Hough: interpolated votes of the maximum; GC: cluster size
    std::vector<Correspondence> correspondences;  // the consistent ones (pose fit inliers)
    float fitness = 0.0f;                        // after verification: inlier fraction (0 when not verified)
    float coverage = 0.0f;                      // inlier model points / model points facing the camera
    float free_space_violation = 0.0f;
    float thickness_ratio = 0.0f;                // fitting points' spread off their best plane / the facing side's
    float continuation = 0.0f;                   // of the rim probes settled either way, the fraction the scene goes on at
    float rmse = 0.0f;                           // of the refined fit (metres)
};

// Hough 3D voting (Tombari & Di Stefano 2010): each correspondence casts a vote for the model's
// reference point (the centroid of the model keypoints), carried into the scene through the two
// BOARD frames; votes are interpolated over the 8 nearest bins of size hough_bin; every local
// maximum with at least hough_threshold votes is an instance, posed by RANSAC + least squares
// (Umeyama) on its voters. Instances sorted by votes (descending), deterministic.
std::vector<Instance> hough_grouping(const Features& model, const Features& scene,
                                     const std::vector<Correspondence>& correspondences, const GroupingParams& params);

// Geometric consistency grouping (as PCL's GeometricConsistencyGrouping): greedy clusters of
// correspondences whose pairwise model and scene distances agree within gc_size.
std::vector<Instance> gc_grouping(const Features& model, const Features& scene,
                                  const std::vector<Correspondence>& correspondences, const GroupingParams& params);

// Least-squares rigid transform mapping `from` onto `to` (Umeyama, no scale).
Pose fit_rigid(std::span<const Point> from, std::span<const Point> to);

}  // namespace mfpc
