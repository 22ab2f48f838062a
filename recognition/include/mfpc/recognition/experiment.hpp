#pragma once

/// @file
/// @brief The paper's experiment (Sections 6-7, Table 2): strategies of foveation compared on one
/// scene, over repeated runs.

#include <cstddef>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/recognition/placement.hpp"
#include "mfpc/recognition/recognize.hpp"

namespace mfpc {

/// @brief One strategy of the paper's experiment (Sections 6-7, Table 2).
///
/// A strategy foveates the scene one way and runs the whole recognition; `serial` runs one
/// single-structure recognition per structure of its config one after another and adds them up
/// (Table 7's FCRM + FCLM, generalised to one fovea per object).
struct ExperimentStrategy {
    std::string name;                           ///< Unique in the config; heads table rows and chart labels.
    FoveationMode mode = FoveationMode::none;   ///< How the scene is foveated (single for a serial strategy).
    bool serial = false;                        ///< One single-structure recognition per structure, added up.
    int structure = 0;               ///< The structure of mode single.
    std::filesystem::path fovea_file;  ///< The foveation config's file; empty for mode none or placement.
    FoveationConfig fovea;             ///< The foveation config read from it.
    /// "fovea": "auto": the structures are placed on every run with this strategy ("placement",
    /// default segments; oracle places from the ground truth), its time counted in the run's.
    std::optional<PlacementStrategy> placement;
};

/// @brief An experiment: one model, one scene with its ground truth, and the strategies compared.
struct ExperimentConfig {
    std::filesystem::path model;         ///< Cloud (.pcd, .ply) or model cache (.mfpcm).
    std::filesystem::path scene;         ///< The scene cloud.
    std::filesystem::path ground_truth;  ///< The scene's ground truth.
    RecognitionParams params;            ///< The recognition parameters of every strategy.
    std::vector<ExperimentStrategy> strategies;  ///< The strategies, in the order they run.
    int runs = 15;                       ///< Runs per strategy.
    int reference = -1;                  ///< The strategy time reductions are relative to (Table 7: MFPC); -1: none.
};

/// @brief Reads an experiment config (JSON; keys in the README, "mfpc experiment").
///
/// Paths are relative to the config's directory. "params" is a parameters file or an inline
/// parameters object. Without a "reference", the reference is the first strategy of mode mfpc that
/// is not serial, if any.
/// @param path The config file.
/// @return The config, its foveation configs read.
/// @throws mfpc::Error naming the key for any malformed config: an unreadable file, invalid JSON,
/// an unknown key, a missing file name, parameters that are not a file name or an object (or that
/// parse_recognition_params refuses), runs not an integer in 1..100000, no strategies, a strategy
/// name that is missing, used twice or holds control characters, '|' or '"', an unknown mode, a
/// foveated mode without a fovea (or mode none with one), a fovea config that cannot be read, a
/// "placement" without "fovea": "auto" or an unknown one, "fovea": "auto" for mode single, a
/// structure given for a mode other than single, a structure the fovea lacks (or none given for a
/// fovea of several), an unknown reference.
ExperimentConfig read_experiment_config(const std::filesystem::path& path);

/// @brief One strategy's outcome. Counts and evaluation do not change from run to run (the pipeline
/// is deterministic), so the first run's stand for all; times do, so every run's are kept.
struct StrategyOutcome {
    std::string name;          ///< The strategy's name.
    /// Summed over the parts (structures) of a serial strategy, but for scene_points and the model's
    /// keypoint counts, which every part shares.
    RecognitionCounts counts;
    Evaluation evaluation;     ///< The score against the ground truth (a serial strategy's parts together).
    std::size_t instances = 0;  ///< Instances found (a serial strategy's parts together).
    std::vector<RecognitionTimings> timings;  ///< One per run (serial: summed over its structures).
    /// The points the strategy described (its first run's foveated cloud; a serial strategy's
    /// parts together), for pictures; empty for mode none, which describes the scene itself.
    PointCloud foveated;
    /// The first run's placement, for a strategy with "fovea": "auto"; absent otherwise.
    std::optional<PlacementResult> placement;
};

/// @brief Runs every strategy `runs` times in turn (strategy by strategy, so caches warm the same
/// way for each) and scores each against the ground truth (with the default EvaluationParams).
/// @param config The experiment.
/// @param model The prepared model.
/// @param scene The scene cloud.
/// @param truth The scene's ground truth.
/// @param progress When given, `progress(done, total)` is called after each run (total: runs times
/// strategies).
/// @return One outcome per strategy, in the config's order.
/// @throws mfpc::Error for runs below 1, or as recognize() and evaluate().
std::vector<StrategyOutcome> run_experiment(const ExperimentConfig& config, const Model& model,
                                            const PointCloud& scene, const GroundTruth& truth,
                                            const std::function<void(int, int)>& progress = {});

}  // namespace mfpc
