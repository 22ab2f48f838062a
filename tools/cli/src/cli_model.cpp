#include <iostream>
#include <memory>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc::cli {
namespace {

nlohmann::ordered_json feature_params_json(const FeatureParams& p)
{
    return nlohmann::ordered_json::parse(to_json(p));
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

}  // namespace mfpc::cli
