#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/recognition/recognize.hpp"

namespace mfpc {

// The paper's experiment (Sections 6-7, Table 2): strategies of foveation compared on one scene.
// A strategy foveates the scene one way and runs the whole recognition; `serial` runs one
// single-structure recognition per structure of its config one after another and adds them up
// (Table 7's FCRM + FCLM, generalised to one fovea per object).
struct ExperimentStrategy {
    std::string name;
    FoveationMode mode = FoveationMode::none;
    bool serial = false;
    int structure = 0;               // the structure of mode single
    std::filesystem::path fovea_file;
    FoveationConfig fovea;
};

struct ExperimentConfig {
    std::filesystem::path model;         // cloud (.pcd, .ply) or model cache (.mfpcm)
    std::filesystem::path scene;
    std::filesystem::path ground_truth;
    RecognitionParams params;
    std::vector<ExperimentStrategy> strategies;
    int runs = 15;
    int reference = -1;                  // the strategy time reductions are relative to (Table 7: MFPC)
};

// Reads an experiment config (JSON; keys in the README, "mfpc experiment"). Paths are relative to
// the config's directory. Any malformed config (unknown key, missing file name, unknown mode, a
// foveated mode without a fovea, a structure the fovea lacks, no strategies, runs < 1, two
// strategies of one name, an unknown reference) throws mfpc::Error naming the key.
ExperimentConfig read_experiment_config(const std::filesystem::path& path);

// One strategy's outcome. Counts and evaluation do not change from run to run (the pipeline is
// deterministic); times do, so every run's are kept.
struct StrategyOutcome {
    std::string name;
    RecognitionCounts counts;  // summed over the runs of a serial strategy
    Evaluation evaluation;
    std::size_t instances = 0;
    std::vector<RecognitionTimings> timings;  // one per run (serial: summed over its structures)
    // The points the strategy described (its first run's foveated cloud; a serial strategy's
    // parts together), for pictures; empty for mode none, which describes the scene itself.
    PointCloud foveated;
};

// Runs every strategy `runs` times in turn (strategy by strategy, so caches warm the same way for
// each) and scores each against the ground truth. `progress(done, total)` is called after each run.
std::vector<StrategyOutcome> run_experiment(const ExperimentConfig& config, const Model& model,
                                            const PointCloud& scene, const GroundTruth& truth,
                                            const std::function<void(int, int)>& progress = {});

}  // namespace mfpc
