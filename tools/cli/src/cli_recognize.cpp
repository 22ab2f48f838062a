#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/recognition/recognition_report.hpp"
#include "mfpc/recognition/recognize.hpp"

namespace mfpc::cli {
namespace {

nlohmann::ordered_json feature_params_json(const FeatureParams& p)
{
    return nlohmann::ordered_json::parse(to_json(p));
}

// Both `model` and `recognize` read --params the same way.
RecognitionParams load_params(const std::string& path)
{
    return path.empty() ? RecognitionParams{} : read_recognition_params(path);
}

struct ModelOptions {
    std::string input;
    std::string output;
    std::string params;
};

void run_model(const ModelOptions& options, const GlobalOptions& global)
{
    if (!is_model_cache(options.output))
        throw CLI::ValidationError("--output", "the model cache must end in .mfpcm");
    const RecognitionParams params = load_params(options.params);
    Stopwatch clock;
    const PointCloud cloud = read_cloud(options.input);
    const double read_ms = clock.lap_ms();
    FeatureTimings timings;
    const Model model = prepare_model(cloud, params.model, options.input, &timings);
    const double prepare_ms = clock.lap_ms();
    write_model_cache(options.output, model);
    if (print_table(global)) {
        print_rows({{"model", options.input},
                    {"points", group_digits(model.points.size())},
                    {"keypoints", group_digits(model.features.size()) + " (" +
                                      group_digits(model.features.invalid) + " invalid dropped)"},
                    {"cache", options.output},
                    {"time (ms)", "read " + format_fixed(read_ms, 1) + "  describe " + format_fixed(prepare_ms, 1)}});
    }
    write_json(global, {{"model", options.input},
                        {"cache", options.output},
                        {"points", model.points.size()},
                        {"keypoints", model.features.size()},
                        {"keypoints_invalid", model.features.invalid},
                        {"params", feature_params_json(model.params)},
                        {"timings_ms",
                         {{"read", read_ms},
                          {"normals", timings.normals_ms},
                          {"lrf", timings.lrf_ms},
                          {"descriptors", timings.descriptors_ms},
                          {"total", prepare_ms}}}});
}

struct RecognizeOptions {
    std::string model;
    std::string scene;
    std::string fovea;
    std::string mode;  // empty: mfpc when --fovea is given
    int structure = -1;
    bool strict = false;
    std::string params;
    std::string ground_truth;
};

void run_recognize(const RecognizeOptions& options, const GlobalOptions& global)
{
    if (!options.mode.empty() && options.fovea.empty() && options.mode != "none")
        throw CLI::ValidationError("--mode", "needs --fovea");
    if (options.strict && options.fovea.empty()) throw CLI::ValidationError("--strict", "needs --fovea");
    const FoveationMode mode = parse_foveation_mode(options.mode.empty() ? (options.fovea.empty() ? "none" : "mfpc")
                                                                         : options.mode,
                                                    "--mode");
    if (options.structure >= 0 && mode != FoveationMode::single)
        throw CLI::ValidationError("--structure", "only applies to --mode single");
    RecognitionParams params = load_params(options.params);
    std::vector<std::string> warnings;
    FoveationConfig config;
    if (!options.fovea.empty())
        config = read_foveation_config(options.fovea, options.strict ? FoveaPolicy::strict : FoveaPolicy::clamp,
                                       &warnings);
    for (const auto& w : warnings) warn(w);
    int single_structure = std::max(options.structure, 0);
    if (mode == FoveationMode::single) {
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

    RecognitionReport report;
    report.model_file = options.model;
    report.scene_file = options.scene;
    report.mode = mode;
    Stopwatch clock;
    report.model_cached = is_model_cache(options.model);
    // Without --params a cache brings its own model parameters.
    const Model model =
        load_model(options.model, params.model, !options.params.empty(), options.params, &report.model_timings);
    report.model_ms = clock.lap_ms();
    if (truth)
        warn_if_truth_of_another_model(truth->model, report.model_cached ? model.source : options.model,
                                       options.ground_truth);
    const PointCloud scene = read_cloud(options.scene);
    report.read_scene_ms = clock.lap_ms();

    const SceneFoveation foveation{options.fovea.empty() ? nullptr : &config, mode, single_structure};
    report.result = recognize(model, scene, params, foveation);
    if (foveation.config != nullptr && mode != FoveationMode::none && report.result.counts.scene_points_used == 0)
        warn("no point of the scene lies inside any structure of " + options.fovea + ": nothing to recognise");
    if (truth) {
        report.evaluation = evaluate(report.result, model, *truth, report.evaluation_params);
        report.ground_truth_file = options.ground_truth;
    }
    report.model_centroid = model_centroid(model);
    report.params = params;
    report.model_params = model.params;
    report.threads = active_threads();
    report.warnings = std::move(warnings);
    if (print_table(global)) std::cout << to_table(report);
    write_json(global, to_json(report));
}

}  // namespace

void add_model_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<ModelOptions>();
    CLI::App* command = app.add_subcommand(
        "model", "Describe a model once (keypoints, BOARD frames, SHOT) and cache it for `mfpc recognize`");
    command->add_option("MODEL", options->input, "Model cloud (.pcd or .ply)")->required();
    command->add_option("-o,--output", options->output, "Model cache to write")->type_name("MODEL.mfpcm")->required();
    command->add_option("-p,--params", options->params, "Recognition parameters (JSON; its \"model\" block is used)")
        ->type_name("PARAMS.json");
    command->callback([options, &global] { run_model(*options, global); });
}

void add_recognize_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<RecognizeOptions>();
    CLI::App* command = app.add_subcommand(
        "recognize", "Find a model's instances in a scene: normals, keypoints, BOARD, SHOT, matching, Hough 3D, "
                     "refinement and verification (paper Section 5)");
    command->add_option("--model", options->model, "Model cloud (.pcd, .ply) or cache from `mfpc model` (.mfpcm)")
        ->type_name("MODEL")
        ->required();
    command->add_option("--scene", options->scene, "Scene cloud (.pcd or .ply)")->type_name("SCENE")->required();
    command->add_option("--fovea", options->fovea, "Foveation config (JSON): foveate the scene first")
        ->type_name("FOVEA.json");
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
    command->callback([options, &global] { run_recognize(*options, global); });
}

}  // namespace mfpc::cli
