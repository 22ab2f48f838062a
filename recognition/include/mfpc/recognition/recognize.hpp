#pragma once

/// @file
/// @brief The whole scene pipeline of recognition: foveation, description, matching, grouping,
/// refinement and verification of one model in one scene.

#include <optional>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/kernels/foveate.hpp"
#include "mfpc/recognition/grouping.hpp"
#include "mfpc/recognition/matching.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

/// @brief What recognize() counted along the way.
struct RecognitionCounts {
    std::size_t scene_points = 0;       ///< Finite scene points.
    std::size_t scene_points_foveated = 0;  ///< Kept by foveation before downsampling (= scene_points without).
    std::size_t redundant_points = 0;       ///< Points raw mode would repeat (paper Eq. 6; 0 without foveation).
    std::size_t scene_points_used = 0;  ///< Described: after foveation, or the voxels at a working resolution (else = scene_points).
    std::size_t scene_keypoints = 0;    ///< With valid frame and descriptor.
    std::size_t scene_keypoints_invalid = 0;  ///< Scene keypoints dropped: no defined frame or descriptor.
    std::size_t model_keypoints = 0;          ///< The model's keypoints (with valid frame and descriptor).
    std::size_t model_keypoints_invalid = 0;  ///< The model's keypoints dropped when it was described.
    std::size_t correspondences = 0;          ///< Correspondences matching found.
    std::size_t instances_before_verification = 0;  ///< Instances grouping found, before refinement and verification.
};

/// @brief Milliseconds per stage of the scene work (model work is apart, in Model preparation).
///
/// Foveation and keypoint sampling run beside the indexing of the whole scene (which goes into
/// normals) when there is more than one thread. Each stage's time is its own, so foveate and
/// normals may add up to more than the total.
struct RecognitionTimings {
    /// @var foveate
    /// Foveation of the scene (0 without).
    /// @var normals
    /// Normal estimation, with the neighbour index it searches (and, at a working resolution, the
    /// resampling and keypoint sampling).
    /// @var keypoints
    /// Keypoint sampling (0 at a working resolution, where it is part of normals).
    /// @var lrf
    /// BOARD frames.
    /// @var descriptors
    /// SHOT descriptors.
    /// @var match
    /// Descriptor matching.
    /// @var group
    /// Grouping and the instances' pose fit.
    /// @var verify
    /// Refinement and verification (0 when both are disabled).
    /// @var total
    /// The whole recognize() call (and the placement, where a caller adds it).
    /// @var place
    /// Automatic fovea placement before the call: recognize() never places, so it is 0 unless the
    /// caller placed the foveae and added the time here and to total (run_experiment does).
    double place = 0, foveate = 0, normals = 0, keypoints = 0, lrf = 0, descriptors = 0, match = 0, group = 0, verify = 0,
           total = 0;
};

/// @brief What recognize() found, with what it found it from.
struct RecognitionResult {
    std::vector<Instance> instances;  ///< The instances, refined and verified as the parameters say, in grouping's order.
    Features scene_features;          ///< The scene's described keypoints (Correspondence::scene numbers them).
    std::vector<Correspondence> correspondences;  ///< Every correspondence matching found.
    RecognitionCounts counts;    ///< What was counted along the way.
    RecognitionTimings timings;  ///< How long each stage took.
    /// The foveated cloud that was described, when SceneFoveation::keep_cloud asked for it (and the
    /// scene was foveated); else empty.
    FoveatedCloud foveated;
};

/// @brief Whether and how recognize() foveates the scene.
struct SceneFoveation {
    const FoveationConfig* config = nullptr;  ///< None: the plain pipeline.
    FoveationMode mode = FoveationMode::mfpc;  ///< How the scene is foveated; none: the plain pipeline.
    int single_structure = 0;                  ///< The structure of mode single.
    bool keep_cloud = false;  ///< Return the foveated cloud in RecognitionResult::foveated.
};

/// @brief The whole scene pipeline: foveate (optional), normals, keypoints (r per region when
/// foveated), BOARD, SHOT, matching, grouping, refinement and verification (as params say).
///
/// A plain scene is described at params.scene.resolution when that is positive, else as sampled
/// with params.scene.keypoint_radius; a foveated one at its levels' densities, with normals as
/// params.normals_from says. Refinement and verification look at the whole scene, whatever
/// foveation kept: they ask whether the sensor saw the model there. One neighbour index over the
/// whole scene serves them and the normals taken from the full scene: a sensor scene's depth image
/// (when fit_camera finds its camera), else a grid.
/// @param model The prepared model.
/// @param scene The scene cloud.
/// @param params The parameters (params.model is only checked: the model was described with its
/// own, Model::params).
/// @param foveation Whether and how the scene is foveated.
/// @return The instances, the scene's features and correspondences, counts and timings.
/// @throws mfpc::Error for parameters check_recognition_params refuses (naming "params"), a scene
/// with no points, or as the stages it runs: foveate, uniform_sampling, the neighbour indices,
/// describe_keypoints (or describe_at_resolution), match_descriptors, the grouping and
/// refine_and_verify. When the foveation and the scene's index both fail, the error is the
/// foveation's, whatever the threads.
RecognitionResult recognize(const Model& model, const PointCloud& scene, const RecognitionParams& params,
                            const SceneFoveation& foveation = {});

}  // namespace mfpc
