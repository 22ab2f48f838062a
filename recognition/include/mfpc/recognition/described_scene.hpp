#pragma once

#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/index/organized_neighbors.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "mfpc/recognition/verification.hpp"

namespace mfpc {

/// A scene described once for any number of models: foveated (optionally), its keypoints, frames
/// and descriptors, and the evidence verification reads. It refers to the scene cloud, which must
/// outlive it, and to its own indexes, so it is neither copied nor moved.
struct DescribedScene {
    DescribedScene() = default;
    DescribedScene(const DescribedScene&) = delete;
    DescribedScene& operator=(const DescribedScene&) = delete;

    const PointCloud* scene = nullptr;       ///< the scene described: the input, or distinct_scene
    PointCloud distinct_scene;               ///< the input with each position once, when it repeats some
    RecognitionParams params;                ///< the parameters of the description and of every model's run
    FoveatedCloud foveated;                  ///< the foveated cloud described (empty without foveation)
    Features features;                       ///< the scene's keypoints, frames and descriptors
    std::optional<OrganizedNeighbors> organized;  ///< the depth-image search (an organized scene)
    std::optional<NeighborGrid> grid;        ///< the grid search (an unorganized scene)
    std::optional<SceneEvidence> evidence;   ///< what verification reads (when refinement or verification is on)
    RecognitionCounts counts;                ///< the scene's part (model counts 0)
    RecognitionTimings timings;              ///< the scene's stages (foveate .. descriptors; total)
    double evidence_ms = 0;                  ///< building `evidence` (inside timings.total)
};

/// Describes a scene as recognize() does before matching: foveation (optional), normals,
/// keypoints, BOARD, SHOT, and the verification evidence. Exact copies of a point are described
/// once (distinct_points): they add no surface, and would make the searches quadratic.
/// @param scene the scene cloud (must outlive the result)
/// @param params the recognition parameters (their scene side; the rest is kept for the models)
/// @param foveation how to foveate the scene first
/// @return the description
/// @throws mfpc::Error for parameters out of range or a scene without finite points
std::unique_ptr<DescribedScene> describe_scene(const PointCloud& scene, const RecognitionParams& params,
                                               const SceneFoveation& foveation = {});

/// Whether recognize_described copies the scene's features into its result.
enum class SceneFeatures {
    copied,    ///< into RecognitionResult::scene_features, which evaluate() and diagnose_truth() read
    left_out,  ///< scene_features left empty, for a caller that reads only instances, counts and timings
};

/// One model's matching, grouping, refinement and verification in a described scene: the same
/// instances as recognize() of that model in that scene. Timings hold only this model's stages.
/// @param described the scene, described once
/// @param model the model to find
/// @param hypotheses when given, receives grouping's instances before refinement and verification
/// (diagnose_truth reads them)
/// @param features whether the scene's features are copied into the result: about 20 MB on a
/// 640x480 Kinect scene at the defaults, once per model (the batch leaves them out)
/// @return the model's result
RecognitionResult recognize_described(const DescribedScene& described, const Model& model,
                                      std::vector<Instance>* hypotheses = nullptr,
                                      SceneFeatures features = SceneFeatures::copied);

/// What a recognize() run leaves for a diagnosis of it (diagnose_truth).
struct RecognitionTrace {
    std::unique_ptr<DescribedScene> described;  ///< the scene as the run described it (refers to its cloud)
    std::vector<Instance> hypotheses;           ///< grouping's instances before refinement and verification
};

/// recognize(), keeping its described scene and grouping's hypotheses: the same result and timings.
/// @param model the model to find
/// @param scene the scene cloud (must outlive trace.described)
/// @param params the recognition parameters
/// @param foveation whether and how the scene is foveated
/// @param trace receives the described scene and the hypotheses
/// @return as recognize()
/// @throws mfpc::Error as recognize()
RecognitionResult recognize_traced(const Model& model, const PointCloud& scene, const RecognitionParams& params,
                                   const SceneFoveation& foveation, RecognitionTrace& trace);

/// Several models in one scene, described once: per model the same instances as recognize() of
/// that model alone, in the models' order.
/// @param models the models to find (none may be null)
/// @param scene the scene cloud
/// @param params the recognition parameters
/// @param foveation how to foveate the scene first
/// @param scene_timings when given, receives the shared description's stage times (its verify:
///        building the evidence)
/// @return one result per model; their timings hold each model's own stages
/// @throws mfpc::Error for a null model, and as describe_scene
std::vector<RecognitionResult> recognize_models(std::span<const Model* const> models, const PointCloud& scene,
                                                const RecognitionParams& params, const SceneFoveation& foveation = {},
                                                RecognitionTimings* scene_timings = nullptr);

}  // namespace mfpc
