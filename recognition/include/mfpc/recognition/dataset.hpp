#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

/// @brief A model of a benchmark set: a cloud (.pcd, .ply) or a model cache (.mfpcm).
struct DatasetModel {
    std::string name;
    std::filesystem::path file;
};

/// @brief A scene of a benchmark set.
struct DatasetScene {
    std::string name;                    ///< unique within the set
    std::string model;                   ///< the DatasetModel::name to look for
    std::filesystem::path cloud;
    std::filesystem::path ground_truth;  ///< empty for a negative scene: nothing may be found
    std::filesystem::path fovea;         ///< optional foveation config: the scene is also run foveated
    std::string group;                   ///< optional label totals are also kept by (a sensor preset)
};

/// @brief A benchmark set: models, positive scenes with their ground truth and negative scenes.
struct Dataset {
    std::string name;
    std::filesystem::path source;  ///< the manifest
    std::vector<DatasetModel> models;
    std::vector<DatasetScene> scenes;
};

/// @brief Reads a dataset manifest (JSON; keys in the README, "mfpc evaluate").
///
/// Model, cloud and ground-truth files are relative to the manifest's "data_dir" (itself relative
/// to the manifest; default its directory), or to `data_dir` when that is not empty; fovea configs
/// are relative to the manifest's directory. Files are not opened here: a missing one is reported
/// by its scene when the set runs.
/// @throws mfpc::Error naming the manifest and the entry for malformed JSON, an unknown or missing
/// key, a wrong type, a scene with both or neither of "ground_truth" and "negative", a model name
/// that no model has, or two models or scenes of one name.
Dataset read_dataset(const std::filesystem::path& path, const std::filesystem::path& data_dir = {});

/// @brief Checks that every file the set names exists, before a long run starts.
/// @throws mfpc::Error naming the manifest, the entry and the path of the first missing file
/// ("set.json: scenes[2].cloud: no such file: ...").
void check_dataset_files(const Dataset& dataset);

/// @brief What evaluate_dataset runs and how it scores.
struct DatasetOptions {
    bool plain = true;     ///< every scene without foveation
    bool foveated = true;  ///< every scene that has a fovea config, foveated (mode mfpc)
    /// Ground-truth instances seen less than this (GroundTruthInstance::visible_fraction) are
    /// tallied apart: a recall goal is for the objects a sensor could be expected to recognise.
    float min_visible_fraction = 0.5f;
    EvaluationParams evaluation;
};

/// @brief One ground-truth instance of a scene and whether a true instance claimed it.
struct TruthOutcome {
    std::string object;            ///< GroundTruthInstance::object (empty when not given)
    float visible_fraction = -1;   ///< -1 when not given
    bool found = false;
};

/// @brief One scene run one way (plain or foveated).
struct SceneOutcome {
    std::string scene;
    std::string model;
    std::string strategy;  ///< "plain" or "fovea"
    std::string group;
    bool negative = false;
    std::string error;     ///< why the scene could not be read or recognised; empty when it ran
    std::size_t instances = 0;  ///< instances found
    Evaluation evaluation;      ///< for a negative scene, every instance is false
    std::vector<TruthOutcome> truth;
    std::size_t scene_points = 0;
    std::size_t scene_keypoints = 0;
    std::size_t correspondences = 0;
    double read_ms = 0;
    double scene_ms = 0;  ///< the scene pipeline (RecognitionTimings::total), reading aside
    RecognitionTimings timings;
    std::size_t peak_memory = 0;  ///< bytes: the process's peak while the scene was read and recognised
    bool peak_memory_reset = false;  ///< false: the system could not reset the mark; the peak is the process's so far
};

/// @brief A model as the set's run prepared it.
struct ModelOutcome {
    std::string name;
    std::string file;
    bool cached = false;
    std::size_t keypoints = 0;
    double ms = 0;      ///< reading and describing (or reading the cache), apart from the scenes
    FeatureParams params;  ///< what the model was described with (a cache's own, when not checked)
    std::string error;  ///< why it could not be loaded; its scenes then carry the same error
};

/// @brief Sums over scene outcomes (a strategy's, or a group's within it). A failed scene's ground
/// truth counts as missed. Correspondence precision pools every scene, negatives too (each
/// correspondence there is wrong); the "fovea" totals cover only the scenes that have a fovea config.
struct DatasetTotals {
    std::size_t scenes = 0, failed = 0;
    std::size_t instances_true = 0, instances_false = 0, instances_missed = 0;
    std::size_t truth = 0;              ///< ground-truth instances
    std::size_t visible = 0, visible_found = 0;  ///< those seen at least min_visible_fraction, and found
    std::size_t false_on_negatives = 0;
    std::size_t correspondences = 0, correct_correspondences = 0, possible_correspondences = 0;
    double sensitivity_sum = 0;         ///< sensitivity weighted by possible correspondences
    std::vector<double> scene_ms;       ///< per scene that ran
    std::size_t peak_memory = 0;        ///< the largest scene's
    double precision() const;           ///< correct / all correspondences, pooled
    double sensitivity() const;         ///< pooled over the possible correspondences
    double recall_visible() const;      ///< visible_found / visible (NaN when none)
    double median_ms() const;
};

/// @brief A tally row: totals of one strategy, over all scenes ("all") or one group or one shape.
struct DatasetTally {
    std::string strategy;
    std::string kind;  ///< "all", "group" or "object"
    std::string key;   ///< the group or object name; empty for "all"
    DatasetTotals totals;
};

struct DatasetReport {
    std::string dataset;
    std::string params_source;
    RecognitionParams params;
    DatasetOptions options;
    int threads = 1;
    std::vector<ModelOutcome> models;
    std::vector<SceneOutcome> scenes;
};

/// @brief Called after each scene run with the runs done, the runs in all, and the scene's name.
using DatasetProgress = std::function<void(std::size_t done, std::size_t total, const std::string& scene)>;

/// @brief Runs every scene of the set (plain and, where it has a fovea, foveated) with `params`
/// and scores it. Each model is loaded once (a cache made with other model parameters is an error
/// when `check_cache_params`, as in `recognize`). A missing file stops the run before it starts
/// (check_dataset_files); a scene whose files exist but fail to read, that fails to recognise, or
/// whose model failed, is an outcome with its error and the run goes on.
DatasetReport evaluate_dataset(const Dataset& dataset, const RecognitionParams& params, bool check_cache_params,
                               const std::string& params_source, const DatasetOptions& options = {},
                               const DatasetProgress& progress = {});

/// @brief The tallies: per strategy over all scenes, then per group and per object shape.
std::vector<DatasetTally> tally(const DatasetReport& report);

/// @brief The whole report as JSON: options, parameters, models, every scene outcome, the tallies.
std::string to_json(const DatasetReport& report);
/// @brief One CSV row per scene outcome, with a header row.
std::string to_csv(const DatasetReport& report);
/// @brief The report as the command line prints it: a row per scene outcome, then the tallies.
std::string to_table(const DatasetReport& report);

}  // namespace mfpc
