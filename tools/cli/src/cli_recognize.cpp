#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/described_scene.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/recognition/placement.hpp"
#include "mfpc/recognition/recognition_report.hpp"
#include "mfpc/recognition/recognize.hpp"

namespace mfpc::cli {
namespace {

struct RecognizeOptions {
    std::vector<std::string> models;
    std::string scene;
    std::string fovea;
    std::string mode;  // empty: mfpc when --fovea is given
    int structure = -1;
    bool strict = false;
    std::string params;
    std::string ground_truth;
    PlacementOptions placement;
};

void run_recognize(const RecognizeOptions& options, const GlobalOptions& global)
{
    if (!options.mode.empty() && options.fovea.empty() && options.mode != "none")
        throw CLI::ValidationError("--mode", "needs --fovea");
    if (options.strict && options.fovea.empty()) throw CLI::ValidationError("--strict", "needs --fovea");
    const bool automatic = is_auto_fovea(options.fovea);
    check_placement_options(options.placement, automatic, "--fovea");
    if (automatic && options.strict) throw CLI::ValidationError("--strict", "does not apply to --fovea auto");
    if (automatic && options.placement.strategy == "oracle" && options.ground_truth.empty())
        throw CLI::ValidationError("--placement oracle", "needs --ground-truth");
    // The structures are only known once placed: a mode that names one of them cannot be checked.
    if (automatic && options.mode == "single")
        throw CLI::ValidationError("--mode single", "needs a config file to choose its structure from, not --fovea auto");
    const FoveationMode mode = parse_foveation_mode(options.mode.empty() ? (options.fovea.empty() ? "none" : "mfpc")
                                                                         : options.mode,
                                                    "--mode");
    if (options.structure >= 0 && mode != FoveationMode::single)
        throw CLI::ValidationError("--structure", "only applies to --mode single");
    RecognitionParams params = load_params(options.params);
    std::vector<std::string> warnings;
    FoveationConfig config;
    if (!options.fovea.empty() && !automatic)
        config = read_foveation_config(options.fovea, options.strict ? FoveaPolicy::strict : FoveaPolicy::clamp,
                                       &warnings);
    for (const auto& w : warnings) warn(w);
    int single_structure = std::max(options.structure, 0);
    if (mode == FoveationMode::single && !automatic) {
        if (options.structure < 0 && config.structures.size() > 1)
            throw CLI::ValidationError("--mode single", "the config has " + std::to_string(config.structures.size()) +
                                                            " structures; choose one with --structure J");
        if (single_structure >= int(config.structures.size()))
            throw CLI::ValidationError("--structure", "structure " + std::to_string(single_structure) +
                                                          " does not exist: the config has " +
                                                          std::to_string(config.structures.size()));
    }
    const std::optional<GroundTruth> truth =
        options.ground_truth.empty() ? std::nullopt : std::optional<GroundTruth>(read_ground_truth(options.ground_truth));

    // One report per model; the scene is read and described once for all of them.
    std::vector<RecognitionReport> reports(options.models.size());
    std::vector<Model> models;
    Stopwatch clock;
    for (std::size_t m = 0; m < options.models.size(); ++m) {
        RecognitionReport& report = reports[m];
        report.model_file = options.models[m];
        report.scene_file = options.scene;
        report.mode = mode;
        report.model_cached = is_model_cache(report.model_file);
        // Without --params a cache brings its own model parameters.
        models.push_back(load_model(report.model_file, params.model, !options.params.empty(), options.params,
                                    &report.model_timings));
        prepare_model_verification(models.back(), params);
        report.model_ms = clock.lap_ms();
        // With several models the ground truth scores the one it was written for.
        const std::string model_file = report.model_cached ? models.back().source : report.model_file;
        if (truth && options.models.size() == 1)
            warn_if_truth_of_another_model(truth->model, model_file, options.ground_truth);
    }
    const PointCloud scene = read_cloud(options.scene);
    const double read_ms = clock.lap_ms();

    std::vector<const Model*> pointers;
    for (const Model& model : models) pointers.push_back(&model);
    // Which model the ground truth scores, and the oracle places: the one it was written for (a
    // cache's by the cloud it was made from), or the only one.
    auto scored_by_truth = [&](std::size_t m) {
        const std::string model_file = reports[m].model_cached ? models[m].source : reports[m].model_file;
        return truth && (models.size() == 1 || truth_is_of(truth->model, model_file));
    };
    std::optional<PlacementResult> placement;
    if (automatic) {
        // The oracle places around the ground truth's instances, of the model it was written for.
        std::vector<PlacedInstance> truth_instances;
        if (truth) {
            std::size_t of = 0;
            while (of < models.size() && !scored_by_truth(of)) ++of;
            if (of == models.size() && options.placement.strategy == "oracle")
                throw CLI::ValidationError("--placement oracle", "the ground truth is of " + truth->model +
                                                                     ", none of the models given");
            for (const GroundTruthInstance& instance : truth->instances)
                truth_instances.push_back({of, instance.transform});
            if (of == models.size()) truth_instances.clear();
        }
        placement = place_for_command(scene, pointers, params, options.placement, truth_instances);
        config = placement->config;
        if (!placement->fallback.empty()) warnings.push_back(placement->fallback);
    }
    // A placement that placed nothing runs the plain pipeline, as its warning says.
    const bool foveated = !options.fovea.empty() && !config.structures.empty();
    const SceneFoveation foveation{foveated ? &config : nullptr, foveated ? mode : FoveationMode::none, single_structure};
    RecognitionTimings scene_timings;
    if (models.size() == 1) {
        reports[0].result = recognize(models[0], scene, params, foveation);
    } else {
        std::vector<RecognitionResult> results = recognize_models(pointers, scene, params, foveation, &scene_timings);
        for (std::size_t m = 0; m < models.size(); ++m) reports[m].result = std::move(results[m]);
    }
    if (foveation.config != nullptr && mode != FoveationMode::none && reports[0].result.counts.scene_points_used == 0)
        warn("no point of the scene lies inside any structure of " +
             (automatic ? std::string("the placement") : options.fovea) + ": nothing to recognise");
    for (std::size_t m = 0; m < models.size(); ++m) {
        RecognitionReport& report = reports[m];
        if (scored_by_truth(m)) {
            report.evaluation = evaluate(report.result, models[m], *truth, report.evaluation_params);
            report.ground_truth_file = options.ground_truth;
        }
        report.read_scene_ms = read_ms;
        report.model_centroid = model_centroid(models[m]);
        report.params = params;
        report.model_params = models[m].params;
        report.threads = active_threads();
        report.warnings = warnings;
        report.placement = placement;
        report.mode = foveation.mode;
        if (print_table(global)) std::cout << (m ? "\n" : "") << to_table(report);
    }
    write_json(global, models.size() == 1 ? to_json(reports[0]) : to_json(std::span<const RecognitionReport>(reports), scene_timings));
}

}  // namespace

void add_recognize_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<RecognizeOptions>();
    CLI::App* command = app.add_subcommand(
        "recognize", "Find a model's instances in a scene: normals, keypoints, BOARD, SHOT, matching, Hough 3D, "
                     "refinement and verification (paper Section 5)");
    command->add_option("--model", options->models,
                        "Model cloud (.pcd, .ply) or cache from `mfpc model` (.mfpcm); repeat to find several "
                        "models, the scene described once")
        ->type_name("MODEL")
        ->required();
    command->add_option("--scene", options->scene, "Scene cloud (.pcd or .ply)")->type_name("SCENE")->required();
    command->add_option("--fovea", options->fovea,
                        "Foveation config (JSON): foveate the scene first; `auto` places the structures from the "
                        "scene and the models (see --placement)")
        ->type_name("FOVEA.json|auto");
    command->add_option("-m,--mode", options->mode, "Foveation mode (default: mfpc with --fovea, none without)")
        ->check(CLI::IsMember({"none", "single", "raw", "mfpc"}));
    command->add_option("--structure", options->structure, "Structure (0-based) to use with --mode single")
        ->check(CLI::NonNegativeNumber);
    command->add_flag("--strict", options->strict, "Reject a fovea outside its outer box instead of clamping it");
    command->add_option("-p,--params", options->params,
                        "Recognition parameters (JSON; keys in the README; default: the built-in set)")
        ->type_name("PARAMS.json");
    command->add_option("--ground-truth", options->ground_truth, "Score the result against this ground truth")
        ->type_name("GT.json");
    add_placement_options(command, options->placement, "--fovea");
    command->callback([options, &global] { run_recognize(*options, global); });
}

}  // namespace mfpc::cli
