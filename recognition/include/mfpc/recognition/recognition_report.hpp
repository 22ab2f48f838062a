#pragma once

/// @file
/// @brief The report of `mfpc recognize` (its JSON and text table), and reading instance poses
/// back from a result or a ground truth.

#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/features.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/recognition/placement.hpp"
#include "mfpc/recognition/recognize.hpp"

namespace mfpc {

/// @brief What `mfpc recognize` reports of one recognition: the inputs named, the result, its score
/// against a ground truth when one was given, and the times of the model and scene work.
struct RecognitionReport {
    std::string model_file;             ///< The model cloud or cache, as given.
    std::string scene_file;             ///< The scene cloud, as given.
    FoveationMode mode = FoveationMode::none;  ///< How the scene was foveated.
    bool model_cached = false;          ///< The model came from a cache (.mfpcm).
    double model_ms = 0;                ///< Reading and describing (or reading from cache) the model.
    FeatureTimings model_timings;       ///< The model's description stages (0 from a cache).
    double read_scene_ms = 0;           ///< Reading the scene cloud.
    Point model_centroid = Point::Zero();  ///< Where an instance's position is taken (model frame).
    RecognitionParams params;           ///< The scene-side parameters recognize() ran with.
    FeatureParams model_params;         ///< The parameters the model was described with.
    RecognitionResult result;           ///< The recognition.
    std::optional<Evaluation> evaluation;  ///< Present when a ground truth was given.
    std::string ground_truth_file;      ///< The ground truth's file, with `evaluation`.
    EvaluationParams evaluation_params; ///< The tolerances `evaluation` was scored with.
    int threads = 1;                    ///< Worker threads of the run.
    std::vector<std::string> warnings;  ///< Warnings the run gave (clamped foveae, ...).
    /// The automatic placement the scene was foveated by (`--fovea auto`); absent otherwise.
    std::optional<PlacementResult> placement;
};

/// @brief The report as JSON text (key names in the README, "mfpc recognize"): per instance its
/// transform (row-major 4x4), the model centroid's position, votes, correspondences and
/// verification scores, and the ground-truth match when evaluated; the counts, the timings in
/// milliseconds, the parameters (the model side as model_params says) and the warnings.
/// @param report The recognition to write; an evaluation must be of its result (one entry per
/// instance).
/// @return Indented JSON text, an object with a final newline.
std::string to_json(const RecognitionReport& report);

/// @brief Several models' reports of one scene as one JSON document: the scene, the shared
/// description's stage times, and each model's report (as to_json of one) under "models".
/// @param reports One per model, all of the same scene.
/// @param scene_timings The shared description's stages (recognize_models; its verify: the evidence).
/// @return Indented JSON text.
/// @throws mfpc::Error for no report.
std::string to_json(std::span<const RecognitionReport> reports, const RecognitionTimings& scene_timings);

/// @brief The report as the text table `mfpc recognize` prints: inputs and counts, one row per
/// instance, the evaluation when present, and the stage times.
/// @param report The recognition to write; an evaluation must be of its result (one entry per
/// instance).
/// @return Text with a final newline.
std::string to_table(const RecognitionReport& report);

/// @brief The instances of a `mfpc recognize` result, or of a ground truth (which has the same keys).
struct InstancePoses {
    std::filesystem::path model;   ///< The model file, resolved as read_instance_poses says.
    std::vector<Pose> transforms;  ///< Model frame -> scene frame, one per instance.
};

/// @brief The most instances read_instance_poses accepts: each is drawn as a whole copy of the
/// model, and 20,000 took over 20 s and 2 GB; a recognised scene holds a handful of objects.
inline constexpr std::size_t max_instance_poses = 1000;

/// @brief Reads the model and the instances' transforms of a recognize result or a ground truth.
///
/// The model file is taken as the user ran `recognize`: relative to the current directory, else
/// beside the file (a result moved with its model, a ground truth beside its model).
/// @param path The JSON file.
/// @return The model file and one transform per instance, in the file's order.
/// @throws mfpc::Error naming the file or the key for an unreadable file, invalid JSON, a missing
/// model or instances, a model found in neither place, more than max_instance_poses instances, or a
/// transform that is not 16 numbers of a rigid motion.
InstancePoses read_instance_poses(const std::filesystem::path& path);

}  // namespace mfpc
