#pragma once

/// @file
/// @brief Benchmark sets: the dataset manifest, running every scene of a set plain and foveated,
/// and the report of the run with its tallies.

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/recognition/placement.hpp"

namespace mfpc {

/// @brief A model of a benchmark set: a cloud (.pcd, .ply) or a model cache (.mfpcm).
struct DatasetModel {
    std::string name;            ///< Unique within the set (default: the file's stem).
    std::filesystem::path file;  ///< The cloud or cache, resolved as read_dataset says.
};

/// @brief A scene of a benchmark set.
struct DatasetScene {
    std::string name;                    ///< Unique within the set (default: the cloud's stem).
    std::string model;                   ///< The DatasetModel::name to look for.
    std::filesystem::path cloud;         ///< The scene cloud.
    std::filesystem::path ground_truth;  ///< Empty for a negative scene: nothing may be found.
    std::filesystem::path fovea;         ///< Optional foveation config: the scene is also run foveated.
    std::string group;                   ///< Optional label totals are also kept by (a sensor preset).
};

/// @brief A benchmark set: models, positive scenes with their ground truth and negative scenes.
struct Dataset {
    std::string name;              ///< The manifest's "name" (default: its file's stem).
    std::filesystem::path source;  ///< The manifest.
    std::vector<DatasetModel> models;  ///< The models, in the manifest's order.
    std::vector<DatasetScene> scenes;  ///< The scenes, in the manifest's order.
};

/// @brief Reads a dataset manifest (JSON; keys in the README, "mfpc evaluate").
///
/// Model, cloud and ground-truth files are relative to the manifest's "data_dir" (itself relative
/// to the manifest; default its directory), or to `data_dir` when that is not empty; fovea configs
/// are relative to the manifest's directory. Files are not opened here: a missing one is reported
/// by its scene when the set runs. A scene may leave out its model in a set of one model.
/// @param path The manifest.
/// @param data_dir When not empty, the directory model, cloud and ground-truth files are relative
/// to, instead of the manifest's "data_dir".
/// @return The set, its files resolved.
/// @throws mfpc::Error naming the manifest and the entry for an unreadable file, malformed JSON, an
/// unknown or missing key, a wrong type, no models or no scenes, a scene with both or neither of
/// "ground_truth" and "negative", a model name that no model has (or none in a set of several
/// models), or two models or scenes of one name.
Dataset read_dataset(const std::filesystem::path& path, const std::filesystem::path& data_dir = {});

/// @brief Checks that every file the set names exists, before a long run starts.
/// @param dataset The set.
/// @throws mfpc::Error naming the manifest, the entry and the path of the first missing file
/// ("set.json: scenes[2].cloud: no such file: ...").
void check_dataset_files(const Dataset& dataset);

/// @brief What evaluate_dataset runs and how it scores.
struct DatasetOptions {
    bool plain = true;     ///< Every scene without foveation.
    bool foveated = true;  ///< Every scene that has a fovea config, foveated (mode mfpc).
    /// Every scene also foveated by each of these automatic placements (a run named after the
    /// strategy; track follows the scenes of one group in the set's order, as frames, and takes a
    /// scene of no group alone). oracle
    /// places from the ground truth: a negative scene gets no structure and nothing is found.
    std::vector<PlacementStrategy> placements;
    PlacementParams placement;  ///< The placements' parameters (each run sets its own strategy).
    /// Ground-truth instances seen less than this (GroundTruthInstance::visible_fraction) are
    /// tallied apart: a recall goal is for the objects a sensor could be expected to recognise.
    float min_visible_fraction = 0.5f;
    EvaluationParams evaluation;  ///< The tolerances every scene is scored with.
    /// Say where each missed true instance was lost (diagnose_truth, on the scored run's own
    /// description and hypotheses). Needs refinement or verification on (the evidence it
    /// re-verifies with); without, nothing is said.
    bool explain = false;
};

/// @brief One ground-truth instance of a scene and whether a true instance claimed it.
struct TruthOutcome {
    std::string object;            ///< GroundTruthInstance::object (empty when not given).
    float visible_fraction = -1;   ///< -1 when not given.
    bool found = false;            ///< Whether a found instance was matched to it.
    /// With DatasetOptions::explain, where a missed instance was lost (to_string(LossStage));
    /// empty when found or not explained.
    std::string lost;
    /// With DatasetOptions::explain and `lost` set, the correspondences correct for it
    /// (TruthDiagnosis::correct_correspondences); -1 when not explained.
    long long correct_correspondences = -1;
};

/// @brief One scene run one way (plain or foveated).
struct SceneOutcome {
    std::string scene;     ///< The scene's name.
    std::string model;     ///< The name of the model looked for.
    std::string strategy;  ///< "plain", "fovea" (the manifest's config) or a placement strategy's name.
    std::string group;     ///< The scene's group (empty when none).
    bool negative = false;  ///< A scene without ground truth: nothing may be found.
    std::string error;     ///< Why the scene could not be read or recognised; empty when it ran.
    std::size_t instances = 0;  ///< Instances found.
    Evaluation evaluation;      ///< For a negative scene, every instance is false.
    std::vector<TruthOutcome> truth;  ///< One per ground-truth instance, in the ground truth's order.
    std::size_t scene_points = 0;     ///< Finite points of the scene cloud.
    std::size_t scene_keypoints = 0;  ///< Scene keypoints described (valid frame and descriptor).
    std::size_t correspondences = 0;  ///< Correspondences matching found.
    double read_ms = 0;   ///< Reading the scene cloud.
    double scene_ms = 0;  ///< Placement (when placed) and the scene pipeline (RecognitionTimings::total), reading aside.
    double placement_ms = 0;      ///< Automatic placement (0 for plain and fovea runs).
    std::size_t structures = 0;   ///< Structures foveated with (0 plain, or a placement's fallback).
    std::size_t points_used = 0;  ///< Points described (RecognitionCounts::scene_points_used).
    std::string fallback;         ///< A placement's fallback (PlacementResult::fallback), else empty.
    RecognitionTimings timings;  ///< The scene pipeline's stages.
    std::size_t peak_memory = 0;  ///< Bytes: the process's peak while the scene was read and recognised.
    bool peak_memory_reset = false;  ///< False: the system could not reset the mark; the peak is the process's so far.
};

/// @brief A model as the set's run prepared it.
struct ModelOutcome {
    std::string name;     ///< The model's name in the set.
    std::string file;     ///< The model's file.
    bool cached = false;  ///< The file is a model cache (.mfpcm).
    std::size_t keypoints = 0;  ///< The model's described keypoints (0 when it could not be loaded).
    double ms = 0;      ///< Reading and describing (or reading the cache), apart from the scenes.
    FeatureParams params;  ///< What the model was described with (a cache's own, when not checked).
    std::string error;  ///< Why it could not be loaded; its scenes then carry the same error.
};

/// @brief Sums over scene outcomes (a strategy's, or a group's within it). A failed scene's ground
/// truth counts as missed. Correspondence precision pools every scene, negatives too (each
/// correspondence there is wrong); the "fovea" totals cover only the scenes that have a fovea config.
struct DatasetTotals {
    /// @var scenes
    /// Scene outcomes summed.
    /// @var failed
    /// Of those, the ones with an error.
    std::size_t scenes = 0, failed = 0;
    /// @var instances_true
    /// Found instances matched to a true instance.
    /// @var instances_false
    /// Found instances matched to none.
    /// @var instances_missed
    /// Ground-truth instances no found instance matched (all those of a failed scene).
    std::size_t instances_true = 0, instances_false = 0, instances_missed = 0;
    /// Of instances_true, those matched by their visible surface alone (Evaluation::instances_true_by_surface).
    std::size_t instances_true_by_surface = 0;
    std::size_t truth = 0;              ///< Ground-truth instances.
    /// @var visible
    /// Ground-truth instances seen at least min_visible_fraction (or whose visibility is not given).
    /// @var visible_found
    /// Of those, the ones found.
    std::size_t visible = 0, visible_found = 0;
    std::size_t false_on_negatives = 0;  ///< False instances on negative scenes.
    /// @var correspondences
    /// Correspondences of the scenes that ran.
    /// @var correct_correspondences
    /// Of those, the correct ones (see evaluate()).
    /// @var possible_correspondences
    /// Possible correspondences (Evaluation::possible_correspondences), summed.
    std::size_t correspondences = 0, correct_correspondences = 0, possible_correspondences = 0;
    double sensitivity_sum = 0;         ///< Sensitivity weighted by possible correspondences.
    std::vector<double> scene_ms;       ///< Per scene that ran.
    std::vector<double> placement_ms;   ///< Per scene that ran (0 for plain and fovea runs).
    std::size_t structures = 0;         ///< Structures, summed over the scenes that ran.
    std::size_t points_used = 0;        ///< Points described, summed over the scenes that ran.
    std::size_t fallbacks = 0;          ///< Scenes where placement placed nothing (run plain).
    std::size_t peak_memory = 0;        ///< The largest scene's.
    /// @brief Correspondence precision, pooled.
    /// @return Correct / all correspondences; 0 without correspondences.
    double precision() const;
    /// @brief Correspondence sensitivity, pooled over the possible correspondences.
    /// @return sensitivity_sum / possible_correspondences; 0 when none is possible.
    double sensitivity() const;
    /// @brief The recall of the visible instances.
    /// @return visible_found / visible (NaN when none).
    double recall_visible() const;
    /// @brief The median scene time.
    /// @return The median of scene_ms (milliseconds); 0 when no scene ran.
    double median_ms() const;
    /// @brief The median placement time.
    /// @return The median of placement_ms (milliseconds); 0 when no scene ran.
    double median_placement_ms() const;
};

/// @brief A tally row: totals of one strategy, over all scenes ("all") or one group or one shape.
struct DatasetTally {
    std::string strategy;  ///< "plain", "fovea" or a placement strategy's name.
    /// "all", "group" or "object". An "object" row holds only the ground-truth counts (truth,
    /// instances_true, instances_missed, visible, visible_found): scene-wide counts do not split by
    /// shape.
    std::string kind;
    std::string key;   ///< The group or object name; empty for "all".
    DatasetTotals totals;  ///< The sums.
};

/// @brief What evaluate_dataset reports: the set, how it ran, and every model and scene outcome.
struct DatasetReport {
    std::string dataset;        ///< The set's name.
    std::string params_source;  ///< Where the parameters came from, as given to evaluate_dataset.
    RecognitionParams params;   ///< The parameters the scenes ran with.
    DatasetOptions options;     ///< What ran and how it was scored.
    int threads = 1;            ///< Worker threads of the run.
    std::vector<ModelOutcome> models;  ///< One per model loaded, in the order first needed.
    /// One per scene run, in the set's order (each scene plain, then foveated, then per placement).
    std::vector<SceneOutcome> scenes;
};

/// @brief Called after each scene run with the runs done, the runs in all, and the scene's name.
using DatasetProgress = std::function<void(std::size_t done, std::size_t total, const std::string& scene)>;

/// @brief Runs every scene of the set (plain, foveated where it has a fovea, and with each of
/// options.placements) with `params`
/// and scores it. Each model is loaded once (a cache made with other model parameters is an error
/// when `check_cache_params`, as in `recognize`). A missing file stops the run before it starts
/// (check_dataset_files); a scene whose files exist but fail to read, that fails to recognise, or
/// whose model failed, is an outcome with its error and the run goes on.
/// @param dataset The set.
/// @param params The recognition parameters (params.model describes the models that are clouds).
/// @param check_cache_params Whether a model cache must have been made with params.model.
/// @param params_source Names the parameters in errors and the report ("params" in errors when
/// empty).
/// @param options What runs and how it is scored.
/// @param progress When given, called after each scene run.
/// @return The report: one outcome per model loaded and per scene run.
/// @throws mfpc::Error for parameters check_recognition_params (or check_placement_params)
/// refuses, a min_visible_fraction
/// outside [0, 1], a missing file (as check_dataset_files), or a scene naming a model the set
/// lacks.
DatasetReport evaluate_dataset(const Dataset& dataset, const RecognitionParams& params, bool check_cache_params,
                               const std::string& params_source, const DatasetOptions& options = {},
                               const DatasetProgress& progress = {});

/// @brief The tallies: per strategy over all scenes, then per group and per object shape.
/// @param report The report.
/// @return Per strategy that ran a scene (in the order they first ran): its "all" row, then one row per
/// group and one per object shape (the ground truth's object name, else the scene's model), each in
/// name order.
std::vector<DatasetTally> tally(const DatasetReport& report);

/// @brief The whole report as JSON: options, parameters, models, every scene outcome, the tallies.
/// @param report The report.
/// @return Indented JSON text with a final newline.
std::string to_json(const DatasetReport& report);
/// @brief One CSV row per scene outcome, with a header row.
/// @param report The report.
/// @return CSV text; a failed scene's row has its error and empty counts.
std::string to_csv(const DatasetReport& report);
/// @brief The report as the command line prints it: a row per scene outcome, then the tallies.
/// @param report The report.
/// @return Text with a final newline.
std::string to_table(const DatasetReport& report);

}  // namespace mfpc
