#include "mfpc/recognition/described_scene.hpp"

#include <chrono>
#include <exception>
#include <memory>
#include <optional>
#include <vector>

#include <tbb/parallel_invoke.h>

#include "mfpc/core/camera.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/index/distinct_points.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/index/organized_neighbors.hpp"
#include "mfpc/kernels/foveate.hpp"
#include "mfpc/kernels/uniform_sampling.hpp"
#include "mfpc/recognition/verification.hpp"

namespace mfpc {
namespace {

using Clock = std::chrono::steady_clock;
double elapsed_ms(Clock::time_point since)
{
    return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

}  // namespace

std::unique_ptr<DescribedScene> describe_scene(const PointCloud& input, const RecognitionParams& params,
                                               const SceneFoveation& foveation)
{
    check_recognition_params(params);
    if (input.empty()) throw Error("recognize", "the scene has no finite points");
    const auto start = Clock::now();
    auto described = std::make_unique<DescribedScene>();
    DescribedScene& d = *described;
    // Exact copies of a point add nothing a sensor saw, but every neighbourhood that holds m of
    // them costs m x m in the searches of normals and verification: the scene is described with
    // each position once.
    const DistinctPoints distinct = distinct_points(input.points);
    if (!distinct.all_distinct()) d.distinct_scene = select(input, distinct.representatives(input.size()));
    const PointCloud& scene = distinct.all_distinct() ? input : d.distinct_scene;
    d.scene = &scene;
    d.params = params;
    d.counts.scene_points = input.size();

    FoveatedCloud& foveated = d.foveated;
    const bool foveating = foveation.config != nullptr && foveation.mode != FoveationMode::none;
    const PointCloud* used = foveating ? &foveated.cloud : &scene;
    std::vector<std::uint32_t> keypoints;
    FeatureTimings feature_timings;
    FeatureTimings resampled_timings;  // apart: the index's time goes into feature_timings meanwhile
    std::size_t resampled_points = 0;
    // A plain scene at a working resolution is resampled and described on its own voxels (beside
    // the whole scene's index, which verification still reads).
    const bool resampled = !foveating && params.scene.resolution > 0.0f;
    const bool full_normals = (params.normals_from == NormalsFrom::full || !foveating) && !resampled;
    const bool verify = params.refine.enabled || params.verify.enabled;
    // One neighbour index over the whole scene serves the normals (when taken from the full scene)
    // and verification: a sensor scene's depth image (the grid's answers, faster; it builds a grid
    // itself only for the few queries the image cannot settle), else a grid.
    std::optional<OrganizedNeighbors>& organized = d.organized;
    std::optional<NeighborGrid>& scene_grid = d.grid;
    // Foveation and keypoints on one side, the whole scene's index and camera on the other: they
    // share nothing, and each scales poorly on its own (the camera fit is serial), so with more
    // than one thread they run side by side. Each stage's time is its own, so foveate and normals
    // may add up to more than the total.
    auto foveate_and_sample = [&] {
        if (foveating) {
            const auto t = Clock::now();
            foveated = foveate(scene, *foveation.config, foveation.mode, foveation.single_structure);
            d.timings.foveate = elapsed_ms(t);
        }
        if (resampled) {
            d.features = describe_at_resolution(scene.points, params.scene, &resampled_timings, {}, &resampled_points);
            return;
        }
        const auto t = Clock::now();
        keypoints = foveating ? uniform_sampling(used->points, foveated.labels, foveation.config->structures)
                              : uniform_sampling(scene.points, params.scene.keypoint_radius);
        d.timings.keypoints = elapsed_ms(t);
    };
    auto index_scene = [&] {
        const auto t = Clock::now();
        if (full_normals || verify) {
            if (const std::optional<Camera> camera = fit_camera(scene))
                organized.emplace(scene, *camera, 3, normal_grid_cell);
            else
                scene_grid.emplace(scene.points, normal_grid_cell);
        }
        feature_timings.normals_ms = elapsed_ms(t);
    };
    // When both fail (a far outlier stops both), the error told is the first stage's whatever the
    // threads: the one a serial run meets first.
    std::exception_ptr sample_error;
    std::exception_ptr index_error;
    auto keeping_error = [](auto& stage, std::exception_ptr& error) {
        return [&stage, &error] {
            try {
                stage();
            } catch (...) {
                error = std::current_exception();
            }
        };
    };
    tbb::parallel_invoke(keeping_error(foveate_and_sample, sample_error), keeping_error(index_scene, index_error));
    if (sample_error) std::rethrow_exception(sample_error);
    if (index_error) std::rethrow_exception(index_error);
    d.counts.scene_points_used = resampled ? resampled_points : used->size();
    d.counts.scene_points_foveated = foveating ? foveated.points_before_downsampling : scene.size();
    d.counts.redundant_points = foveated.redundant_points;

    auto t = Clock::now();
    std::optional<NeighborGrid> foveated_grid;
    if (!full_normals && !resampled) {
        // Cells of 3 voxels of the finest level, as describe_at_resolution sizes them: the k
        // nearest of a cloud downsampled at d lie within a few d, and cells of normal_grid_cell
        // made the search of a foveated room (d_m 5 mm, d_0 2 cm) read hundreds of cells a point.
        float finest = 0;
        for (const FoveatedStructure& structure : foveation.config->structures) {
            const float d = structure.density(structure.levels);
            if (d > 0) finest = finest > 0 ? std::min(finest, d) : d;
        }
        foveated_grid.emplace(used->points, std::max(normal_grid_cell, 3.0f * finest));
    }
    feature_timings.normals_ms += elapsed_ms(t);
    if (!resampled) {
        d.features =
            !full_normals ? describe_keypoints(used->points, keypoints, *foveated_grid, params.scene, &feature_timings)
            : organized   ? describe_keypoints(used->points, keypoints, *organized, params.scene, &feature_timings)
                          : describe_keypoints(used->points, keypoints, *scene_grid, params.scene, &feature_timings);
    }
    feature_timings.normals_ms += resampled_timings.normals_ms;
    feature_timings.lrf_ms += resampled_timings.lrf_ms;
    feature_timings.descriptors_ms += resampled_timings.descriptors_ms;
    d.timings.normals = feature_timings.normals_ms;
    d.timings.lrf = feature_timings.lrf_ms;
    d.timings.descriptors = feature_timings.descriptors_ms;
    d.counts.scene_keypoints = d.features.size();
    d.counts.scene_keypoints_invalid = d.features.invalid;

    if (verify) {
        // Verification looks at the whole scene, whatever foveation kept: it asks whether the
        // sensor saw the model there.
        t = Clock::now();
        d.evidence.emplace(organized ? make_scene_evidence(scene, *organized)
                                     : make_scene_evidence(scene, *scene_grid, std::nullopt));
        d.evidence_ms = elapsed_ms(t);
    }
    d.timings.total = elapsed_ms(start);
    return described;
}

RecognitionResult recognize_described(const DescribedScene& described, const Model& model,
                                      std::vector<Instance>* hypotheses, SceneFeatures features)
{
    const auto start = Clock::now();
    const RecognitionParams& params = described.params;
    RecognitionResult result;
    if (features == SceneFeatures::copied) result.scene_features = described.features;
    result.counts = described.counts;
    result.counts.model_keypoints = model.features.size();
    result.counts.model_keypoints_invalid = model.features.invalid;

    auto t = Clock::now();
    result.correspondences = match_descriptors(model.features, described.features, params.match);
    result.counts.correspondences = result.correspondences.size();
    result.timings.match = elapsed_ms(t);

    t = Clock::now();
    result.instances = params.grouping.method == Grouping::hough
                           ? hough_grouping(model.features, described.features, result.correspondences, params.grouping)
                           : gc_grouping(model.features, described.features, result.correspondences, params.grouping);
    result.counts.instances_before_verification = result.instances.size();
    result.timings.group = elapsed_ms(t);
    if (hypotheses) *hypotheses = result.instances;

    if (described.evidence) {
        t = Clock::now();
        const ModelVerification* prepared = model.verification && prepared_for(*model.verification, params.refine,
                                                                                params.verify)
                                                ? model.verification.get()
                                                : nullptr;
        result.instances = refine_and_verify(std::move(result.instances), model.points, model.normals,
                                             *described.evidence, params.refine, params.verify, prepared);
        result.timings.verify = elapsed_ms(t);
    }
    result.timings.total = elapsed_ms(start);
    return result;
}

namespace {

// recognize_described for the description's last use: its features moved into the result rather
// than copied (tens of megabytes on a Kinect scene).
RecognitionResult recognize_last(DescribedScene& described, const Model& model)
{
    RecognitionResult result = recognize_described(described, model, nullptr, SceneFeatures::left_out);
    result.scene_features = std::move(described.features);
    return result;
}

// recognize(), handing its described scene and hypotheses to `trace` when given.
RecognitionResult recognize_once(const Model& model, const PointCloud& scene, const RecognitionParams& params,
                                 const SceneFoveation& foveation, RecognitionTrace* trace)
{
    const auto start = Clock::now();
    std::unique_ptr<DescribedScene> described = describe_scene(scene, params, foveation);
    // The trace keeps the described scene, features and all.
    RecognitionResult result =
        trace ? recognize_described(*described, model, &trace->hypotheses) : recognize_last(*described, model);
    // One model: the scene's stages and the model's as one run, the evidence counted as verification.
    const RecognitionTimings& scene_timings = described->timings;
    result.timings.foveate = scene_timings.foveate;
    result.timings.normals = scene_timings.normals;
    result.timings.keypoints = scene_timings.keypoints;
    result.timings.lrf = scene_timings.lrf;
    result.timings.descriptors = scene_timings.descriptors;
    if (described->evidence) result.timings.verify += described->evidence_ms;
    result.timings.total = elapsed_ms(start);
    if (foveation.keep_cloud) result.foveated = std::move(described->foveated);
    if (trace) trace->described = std::move(described);
    return result;
}

}  // namespace

RecognitionResult recognize(const Model& model, const PointCloud& scene, const RecognitionParams& params,
                            const SceneFoveation& foveation)
{
    return recognize_once(model, scene, params, foveation, nullptr);
}

RecognitionResult recognize_traced(const Model& model, const PointCloud& scene, const RecognitionParams& params,
                                   const SceneFoveation& foveation, RecognitionTrace& trace)
{
    return recognize_once(model, scene, params, foveation, &trace);
}

std::vector<RecognitionResult> recognize_models(std::span<const Model* const> models, const PointCloud& scene,
                                                const RecognitionParams& params, const SceneFoveation& foveation,
                                                RecognitionTimings* scene_timings)
{
    for (const Model* model : models)
        if (model == nullptr) throw Error("recognize", "a model to recognise is missing (null)");
    std::unique_ptr<DescribedScene> described = describe_scene(scene, params, foveation);
    if (scene_timings) {
        *scene_timings = described->timings;
        scene_timings->verify = described->evidence_ms;
    }
    // Models in turn, each stage parallel inside: one scene's description is shared, not copied
    // across threads, and results come out in the models' order whatever the threads.
    std::vector<RecognitionResult> results;
    results.reserve(models.size());
    // Each result holds the scene's features: copies, and the last model's moved in.
    for (std::size_t m = 0; m < models.size(); ++m)
        results.push_back(m + 1 < models.size() ? recognize_described(*described, *models[m])
                                                : recognize_last(*described, *models[m]));
    return results;
}

}  // namespace mfpc
