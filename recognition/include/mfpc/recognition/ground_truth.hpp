#pragma once

/// @file
/// @brief Ground truth of a scene (the shared *.gt.json format): the true poses of the model's
/// instances.

#include <filesystem>
#include <string>
#include <vector>

#include "mfpc/core/pose.hpp"

namespace mfpc {

/// @brief One true instance of the model in a scene.
///
/// Ground truth of a scene (the shared *.gt.json format):
///
///     {"model": "<file>", "instances": [{"transform": [16 numbers, row-major 4x4]}, ...]}
///
/// Each transform maps model coordinates into scene coordinates. Instances may carry an "object"
/// name, a "visible_points" count and a "visible_fraction" in 0..1 (written by the synthetic
/// scanner); all optional.
///
/// An instance may also carry the object's rotational symmetry, "symmetry": {"axis": [x, y, z],
/// "order": N}: turning the model by 360/N degrees about `axis` (in model coordinates, through the
/// model's origin) leaves it unchanged; N = 0 means any angle (a bottle). A pose off by such a turn
/// is then as right as the transform given (a carton turned half a turn looks the same). The
/// symmetry may also hold "flip": {"axis": [x, y, z], "point": [x, y, z]}: a half-turn about the
/// line through `point` along `axis`, perpendicular to the symmetry axis, leaves the object
/// unchanged too (a box turned upside down about its mid-height: the dihedral symmetry of order N).
struct GroundTruthInstance {
    Pose transform = Pose::Identity();  ///< Maps model coordinates into scene coordinates.
    std::string object;                 ///< The object's name; empty when not given.
    long visible_points = -1;  ///< -1 when not given.
    /// Share of the object's surface the sensor would see from this camera with nothing in the way
    /// and no image border that it does see (occlusion and the border's cut); -1 when not given.
    float visible_fraction = -1.0f;
    Eigen::Vector3f symmetry_axis = Eigen::Vector3f::UnitZ();  ///< The symmetry axis, in model coordinates.
    int symmetry_order = 1;    ///< 1: no symmetry; 0: continuous.
    bool symmetry_flip = false;  ///< Whether the half-turn about the flip line is a symmetry too.
    Eigen::Vector3f flip_axis = Eigen::Vector3f::UnitX();  ///< The flip line's direction (model coordinates, unit).
    Eigen::Vector3f flip_point = Eigen::Vector3f::Zero();  ///< A point of the flip line (model coordinates).

    /// @brief The transforms that place the object identically: transform composed with each turn
    /// of the symmetry (a continuous symmetry is sampled every degree), and with a flip each of
    /// those composed with the half-turn about the flip line.
    /// @return symmetry_order transforms (360 for a continuous symmetry), twice as many with a
    /// flip, the first the transform itself.
    std::vector<Pose> equivalent_transforms() const;
};

/// @brief The ground truth of a scene: the model file and its true instances.
struct GroundTruth {
    std::string model;                           ///< The model file; empty when not given.
    std::vector<GroundTruthInstance> instances;  ///< The true instances.
};

/// @brief Reads a scene's ground truth (*.gt.json).
/// @param path The file.
/// @return The ground truth.
/// @throws mfpc::Error naming the file and the key on any malformed input (unreadable file, bad
/// JSON, an unknown key, a missing or mistyped value, a pose that is not rigid).
GroundTruth read_ground_truth(const std::filesystem::path& path);

}  // namespace mfpc
