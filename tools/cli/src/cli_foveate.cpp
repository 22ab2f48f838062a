#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/index/point_index.hpp"
#include "mfpc/kernels/foveate.hpp"
#include "mfpc/recognition/foveation_report.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/placement.hpp"
#include "mfpc/simulation/primitive_scene.hpp"

namespace mfpc::cli {

namespace {

struct FoveateOptions {
    std::string input;
    bool procedural = false;
    std::uint32_t procedural_seed = 1;
    std::uint32_t procedural_objects = 4;
    std::string config;
    std::string mode = "mfpc";
    std::string downsample;  // empty: the config's
    int structure = -1;      // for mode single
    bool strict = false;
    std::string output;
    std::string encoding = "binary";
    std::string regions_dir;
    float index_voxel = PointIndexParams{}.voxel_size;
    std::vector<std::string> models;  // --config auto sizes the structures from them
    std::string params;
    PlacementOptions placement;
};

void run_foveate(const FoveateOptions& options, const GlobalOptions& global)
{
    // Everything that can be checked before the work is checked first.
    const FoveationMode mode = parse_foveation_mode(options.mode, "--mode");
    const CloudWriteOptions write_options{parse_cloud_encoding(options.encoding, "--encoding"), false};
    if (options.procedural == !options.input.empty()) {
        throw CLI::ValidationError("foveate", "give exactly one of IN and --procedural");
    }
    if (options.config.empty() && !options.procedural && mode != FoveationMode::none) {
        throw CLI::ValidationError("foveate", "--config is required (except with --procedural or --mode none)");
    }
    if (mode != FoveationMode::single && options.structure >= 0) {
        throw CLI::ValidationError("--structure", "only applies to --mode single");
    }
    if (!options.output.empty()) check_cloud_write_options(options.output, write_options);
    const bool automatic = is_auto_fovea(options.config);
    check_placement_options(options.placement, automatic, "--config");
    if (automatic && options.models.empty()) throw CLI::ValidationError("--config auto", "needs --model");
    if (!automatic && !options.models.empty()) throw CLI::ValidationError("--model", "needs --config auto");
    if (!automatic && !options.params.empty()) throw CLI::ValidationError("--params", "needs --config auto");
    if (automatic && options.placement.strategy == "oracle")
        throw CLI::ValidationError("--placement oracle", "needs a ground truth: use `mfpc recognize --ground-truth`");
    if (automatic && options.strict) throw CLI::ValidationError("--strict", "does not apply to --config auto");
    if (automatic && mode == FoveationMode::single)
        throw CLI::ValidationError("--mode single", "needs a config file to choose its structure from, not --config auto");

    Stopwatch clock;
    Stopwatch total_clock;
    FoveationReport report;
    FoveationConfig config;
    const FoveaPolicy policy = options.strict ? FoveaPolicy::strict : FoveaPolicy::clamp;
    if (!options.config.empty() && !automatic) config = read_foveation_config(options.config, policy, &report.warnings);
    const RecognitionParams params = load_params(options.params);
    std::vector<Model> models;
    for (const std::string& file : options.models)
        models.push_back(load_model(file, params.model, !options.params.empty(), options.params));
    if (automatic) report.timings_ms.emplace_back("models", clock.lap_ms());
    for (const auto& w : report.warnings) warn(w);

    // The cloud (and, for the primitive scene, its config unless one was given).
    PointCloud cloud;
    report.input = options.input;
    if (options.procedural) {
        PrimitiveSceneParams params;
        params.seed = options.procedural_seed;
        params.objects = options.procedural_objects;
        PrimitiveScene scene = make_primitive_scene(params);
        cloud = std::move(scene.cloud);
        if (options.config.empty()) config = std::move(scene.fovea);
        report.points_in = cloud.source_size();
        report.points_finite = cloud.size();
        report.input = "procedural scene (seed " + std::to_string(params.seed) + ", " +
                       std::to_string(params.objects) + " objects)";
        report.timings_ms.emplace_back("generate", clock.lap_ms());
    } else {
        CloudReadReport read;
        cloud = read_cloud(options.input, &read);
        report.points_in = read.points_in;
        report.points_finite = read.points_finite;
        report.timings_ms.emplace_back("read", clock.lap_ms());
    }
    FoveationMode run_mode = mode;
    if (automatic) {
        std::vector<const Model*> pointers;
        for (const Model& model : models) pointers.push_back(&model);
        report.placement = place_for_command(cloud, pointers, params, options.placement);
        config = report.placement->config;
        report.timings_ms.emplace_back("place", clock.lap_ms());
        // Nothing placed: the cloud passes unchanged, as the warning says.
        if (config.structures.empty()) {
            report.warnings.push_back(report.placement->fallback);
            run_mode = FoveationMode::none;
        }
    }
    if (!options.downsample.empty()) config.downsample = parse_downsample(options.downsample, "--downsample");

    int single_structure = 0;
    if (run_mode == FoveationMode::single) {
        if (options.structure >= int(config.structures.size())) {
            throw CLI::ValidationError("--structure", "structure " + std::to_string(options.structure) +
                                                          " does not exist: the config has " +
                                                          std::to_string(config.structures.size()));
        }
        if (options.structure < 0 && config.structures.size() > 1) {
            throw CLI::ValidationError("--mode single", "the config has " + std::to_string(config.structures.size()) +
                                                            " structures; choose one with --structure J");
        }
        single_structure = std::max(options.structure, 0);
    }

    const PointIndex index(cloud, PointIndexParams{options.index_voxel});
    report.timings_ms.emplace_back("index", clock.lap_ms());
    const FoveatedCloud result = foveate(cloud, index, config, run_mode, single_structure);
    const double foveate_ms = clock.lap_ms();
    // foveate() times its two phases; mode none has neither (its copy counts as downsampling).
    report.timings_ms.emplace_back("label", result.label_ms);
    report.timings_ms.emplace_back("downsample", run_mode == FoveationMode::none ? foveate_ms : result.downsample_ms);

    // The foveated cloud and the region clouds are written all or none: a failure half-way keeps
    // every earlier file as it was.
    StagedFiles outputs;
    if (!options.output.empty()) {
        if (result.cloud.empty()) {
            throw Error(options.output, "nothing to write: no point of the cloud lies inside any structure");
        }
        outputs.stage(options.output, cloud_file_bytes(options.output, result.cloud, write_options));
    } else if (result.cloud.empty()) {
        warn("no point of the cloud lies inside any structure");
    }
    bool created = false;  // the regions' directory, made by this run
    try {
        if (!options.regions_dir.empty()) {
            const std::filesystem::path directory(options.regions_dir);
            std::error_code error;
            created = std::filesystem::create_directories(directory, error);
            if (error) throw Error(options.regions_dir, "cannot create directory: " + error.message());
            for (const RegionCloud& region : region_clouds(result)) {
                const std::filesystem::path path = directory / region.file_name;
                outputs.stage(path, cloud_file_bytes(path, region.cloud, write_options));
            }
        }
        outputs.commit();
    } catch (...) {
        outputs.discard();
        std::error_code ignored;
        if (created) std::filesystem::remove(options.regions_dir, ignored);  // only if empty
        throw;
    }
    report.timings_ms.emplace_back("write", clock.lap_ms());
    report.timings_ms.emplace_back("total", total_clock.lap_ms());

    report.output = options.output;
    report.mode = run_mode;
    report.single_structure = single_structure;
    report.downsample = config.downsample;
    report.structures = config.structures.size();
    report.levels = config.levels();
    report.result = &result;
    report.threads = active_threads();
    if (print_table(global)) std::cout << to_table(report);
    write_json(global, to_json(report));
}

}  // namespace

void add_foveate_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<FoveateOptions>();
    CLI::App* command = app.add_subcommand(
        "foveate", "Foveate a cloud: keep full density in each fovea and less in each outer level (paper Section 4)");
    command->add_option("IN", options->input, "Input cloud (.pcd or .ply)");
    command->add_flag("--procedural", options->procedural,
                      "Use the built-in procedural tabletop scene (primitives intersected analytically) instead of IN, with one structure per object "
                      "unless --config is given");
    command->add_option("--procedural-seed", options->procedural_seed, "Seed of the procedural scene")
        ->capture_default_str();
    command->add_option("--procedural-objects", options->procedural_objects, "Objects in the procedural scene")
        ->check(CLI::Range(1, 8))
        ->capture_default_str();
    command->add_option("-c,--config", options->config,
                        "Foveation config (JSON; keys in the README); `auto` places the structures from the cloud "
                        "and --model (see --placement)")
        ->type_name("FOVEA.json|auto");
    command->add_option("--model", options->models,
                        "With --config auto: a model to place structures for (cloud or .mfpcm cache); repeat for "
                        "several")
        ->type_name("MODEL");
    command->add_option("-p,--params", options->params,
                        "With --config auto: recognition parameters whose scene side sizes the structures (JSON; "
                        "default: the built-in set)")
        ->type_name("PARAMS.json");
    add_placement_options(command, options->placement, "--config");
    command->add_option("-m,--mode", options->mode,
                        "none: no foveation; single: one structure (FPC); raw: each structure on its own, "
                        "concatenated; mfpc: redundancy-treated multifoveation")
        ->check(CLI::IsMember({"none", "single", "raw", "mfpc"}))
        ->capture_default_str();
    command->add_option("-d,--downsample", options->downsample,
                        "voxel: centroid per voxel; uniform: original point nearest each voxel centre "
                        "(default: the config's, else voxel)")
        ->check(CLI::IsMember({"voxel", "uniform"}));
    command->add_option("--structure", options->structure, "Structure (0-based) to use with --mode single")
        ->check(CLI::NonNegativeNumber);
    command->add_flag("--strict", options->strict,
                      "Reject a fovea outside its outer box instead of clamping it with a warning");
    command->add_option("-o,--output", options->output, "Write the foveated cloud here (.pcd or .ply)")
        ->type_name("OUT");
    command->add_option("--encoding", options->encoding, "Output encoding")
        ->check(CLI::IsMember({"ascii", "binary", "binary_compressed"}))
        ->capture_default_str();
    command->add_option("--regions-dir", options->regions_dir,
                        "Also write one PCD per region (structureL_levelK.pcd) into DIR")
        ->type_name("DIR");
    command->add_option("--index-voxel", options->index_voxel, "Voxel size of the sparse index (metres)")
        ->check(CLI::Validator(
            [](std::string& text) {
                // A number at least the smallest voxel OpenVDB's transforms take (NaN fails the test).
                const double value = std::strtod(text.c_str(), nullptr);
                return value >= double(min_index_voxel_size) && std::isfinite(value)
                           ? std::string()
                           : "must be a number of at least " + format_number(min_index_voxel_size) + " (metres)";
            },
            "SIZE"))
        ->capture_default_str();
    command->callback([options, &global] { run_foveate(*options, global); });
}

}  // namespace mfpc::cli
