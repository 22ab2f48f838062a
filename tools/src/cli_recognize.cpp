#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include <tbb/global_control.h>

#include "cli_commands.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/recognition/recognize.hpp"

namespace mfpc::cli {
namespace {

nlohmann::ordered_json feature_params_json(const FeatureParams& p)
{
    return nlohmann::ordered_json::parse(to_json(p));
}

nlohmann::ordered_json row_major(const Pose& pose)
{
    nlohmann::ordered_json out = nlohmann::ordered_json::array();
    for (double v : pose_to_row_major(pose)) out.push_back(v);
    return out;
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

    Stopwatch clock;
    FeatureTimings model_timings;
    const bool cached = is_model_cache(options.model);
    // Without --params a cache brings its own model parameters.
    const Model model = load_model(options.model, params.model, !options.params.empty(), options.params, &model_timings);
    params.model = model.params;
    const double model_ms = clock.lap_ms();
    if (truth) warn_if_truth_of_another_model(truth->model, cached ? model.source : options.model, options.ground_truth);
    CloudReadReport report;
    const PointCloud scene = read_cloud(options.scene, &report);
    const double read_ms = clock.lap_ms();

    const SceneFoveation foveation{options.fovea.empty() ? nullptr : &config, mode, single_structure};
    const RecognitionResult result = recognize(model, scene, params, foveation);
    if (foveation.config != nullptr && mode != FoveationMode::none && result.counts.scene_points_used == 0)
        warn("no point of the scene lies inside any structure of " + options.fovea + ": nothing to recognise");
    const std::optional<Evaluation> evaluation =
        truth ? std::optional<Evaluation>(evaluate(result, model, *truth)) : std::nullopt;

    // Where each instance puts the object: the model's centroid in the scene.
    const Point centroid = model_centroid(model);
    nlohmann::ordered_json instances = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < result.instances.size(); ++i) {
        const Instance& instance = result.instances[i];
        const Point position = instance.transform * centroid;
        nlohmann::ordered_json item = {{"transform", row_major(instance.transform)},
                                       {"position", {position.x(), position.y(), position.z()}},
                                       {"votes", instance.votes},
                                       {"correspondences", instance.correspondences.size()},
                                       {"fitness", instance.fitness},
                                       {"coverage", instance.coverage},
                                       {"free_space_violation", instance.free_space_violation},
                                       {"thickness_ratio", instance.thickness_ratio},
                                       {"continuation", instance.continuation},
                                       {"rmse", instance.rmse}};
        if (evaluation) {
            item["ground_truth_instance"] = evaluation->instance_match[i];
            item["position_error_m"] = evaluation->position_error[i];
            item["rotation_error_deg"] = evaluation->rotation_error_deg[i];
        }
        instances.push_back(item);
    }
    const auto& c = result.counts;
    const auto& t = result.timings;
    nlohmann::ordered_json json = {
        {"model", options.model},
        {"scene", options.scene},
        {"mode", to_string(mode)},
        {"instances", instances},
        {"counts",
         {{"scene_points", c.scene_points},
          {"scene_points_used", c.scene_points_used},
          {"scene_keypoints", c.scene_keypoints},
          {"scene_keypoints_invalid", c.scene_keypoints_invalid},
          {"model_keypoints", c.model_keypoints},
          {"model_keypoints_invalid", c.model_keypoints_invalid},
          {"correspondences", c.correspondences},
          {"instances_before_verification", c.instances_before_verification}}},
        {"timings_ms",
         {{"read_scene", read_ms},
          {"foveate", t.foveate},
          {"normals", t.normals},
          {"keypoints", t.keypoints},
          {"lrf", t.lrf},
          {"descriptors", t.descriptors},
          {"match", t.match},
          {"group", t.group},
          {"verify", t.verify},
          {"total", t.total}}},
        {"model_timings_ms",
         {{"cached", cached},
          {"total", model_ms},
          {"normals", model_timings.normals_ms},
          {"lrf", model_timings.lrf_ms},
          {"descriptors", model_timings.descriptors_ms}}},
        {"threads", tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)},
        {"params", nlohmann::ordered_json::parse(to_json(params))},
        {"warnings", warnings},
    };
    if (evaluation) {
        json["evaluation"] = {{"ground_truth", options.ground_truth},
                              {"instances_true", evaluation->instances_true},
                              {"instances_false", evaluation->instances_false},
                              {"instances_missed", evaluation->instances_missed},
                              {"correct_correspondences", evaluation->correct_correspondences},
                              {"possible_correspondences", evaluation->possible_correspondences},
                              {"correspondence_precision", evaluation->correspondence_precision},
                              {"correspondence_sensitivity", evaluation->correspondence_sensitivity},
                              {"tolerances",
                               {{"correspondence_m", EvaluationParams{}.correspondence_tolerance},
                                {"instance_m", EvaluationParams{}.instance_translation},
                                {"instance_deg", EvaluationParams{}.instance_angle_deg}}}};
    }

    if (print_table(global)) {
        print_rows({{"model", options.model + (cached ? " (cached)" : "")},
                    {"scene", options.scene},
                    {"mode", to_string(mode)},
                    {"scene points", group_digits(c.scene_points) + " finite, " + group_digits(c.scene_points_used) +
                                         " used"},
                    {"keypoints", group_digits(c.scene_keypoints) + " scene (" + group_digits(c.scene_keypoints_invalid) +
                                      " invalid), " + group_digits(c.model_keypoints) + " model"},
                    {"correspondences", group_digits(c.correspondences)},
                    {"instances", group_digits(result.instances.size()) + " (" +
                                      group_digits(c.instances_before_verification) + " before verification)"}});
        if (!result.instances.empty()) {
            std::cout << "\n  #  position (m)                 votes  corrs  fitness  free-space";
            if (evaluation) std::cout << "  ground truth";
            std::cout << '\n';
            for (std::size_t i = 0; i < result.instances.size(); ++i) {
                const Instance& instance = result.instances[i];
                const Point p = instance.transform * centroid;
                char line[160];
                std::snprintf(line, sizeof line, "%3zu  (%7.3f, %7.3f, %7.3f)  %6.1f  %5zu  %7.3f  %10.3f", i, p.x(),
                              p.y(), p.z(), instance.votes, instance.correspondences.size(), instance.fitness,
                              instance.free_space_violation);
                std::cout << line;
                if (evaluation) {
                    const int match = evaluation->instance_match[i];
                    std::cout << "  " << (match >= 0 ? "instance " + std::to_string(match) : std::string("false")) << " ("
                              << format_fixed(evaluation->position_error[i] * 1000.0, 1) << " mm, "
                              << format_fixed(evaluation->rotation_error_deg[i], 2) << " deg)";
                }
                std::cout << '\n';
            }
        }
        if (evaluation) {
            std::cout << "\nevaluation  true " << evaluation->instances_true << "  false " << evaluation->instances_false
                      << "  missed " << evaluation->instances_missed << "  correct correspondences "
                      << evaluation->correct_correspondences << "  precision "
                      << format_fixed(evaluation->correspondence_precision, 3) << "  sensitivity "
                      << format_fixed(evaluation->correspondence_sensitivity, 3) << '\n';
        }
        std::cout << "\ntimings (ms)  foveate " << format_fixed(t.foveate, 1) << "  normals " << format_fixed(t.normals, 1)
                  << "  keypoints " << format_fixed(t.keypoints, 1) << "  lrf " << format_fixed(t.lrf, 1)
                  << "  descriptors " << format_fixed(t.descriptors, 1) << "  match " << format_fixed(t.match, 1)
                  << "  group " << format_fixed(t.group, 1) << "  verify " << format_fixed(t.verify, 1) << "  total "
                  << format_fixed(t.total, 1) << "\nmodel (ms)    " << (cached ? "read from cache " : "described ")
                  << format_fixed(model_ms, 1) << '\n';
    }
    write_json(global, json);
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
