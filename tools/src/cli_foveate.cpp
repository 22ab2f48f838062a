#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>

#include <tbb/global_control.h>

#include "cli_commands.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/index/point_index.hpp"
#include "mfpc/kernels/foveate.hpp"
#include "mfpc/tools/procedural_scene.hpp"

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

    Stopwatch clock;
    Stopwatch total_clock;
    nlohmann::ordered_json timings;

    FoveationConfig config;
    std::vector<std::string> warnings;
    const FoveaPolicy policy = options.strict ? FoveaPolicy::strict : FoveaPolicy::clamp;
    if (!options.config.empty()) config = read_foveation_config(options.config, policy, &warnings);
    for (const auto& w : warnings) warn(w);

    // The cloud (and, for the procedural scene, its config unless one was given).
    PointCloud cloud;
    CloudReadReport report;
    std::string input = options.input;
    if (options.procedural) {
        ProceduralSceneParams params;
        params.seed = options.procedural_seed;
        params.objects = options.procedural_objects;
        ProceduralScene scene = make_procedural_scene(params);
        cloud = std::move(scene.cloud);
        if (options.config.empty()) config = std::move(scene.fovea);
        report.points_in = cloud.source_size();
        report.points_finite = cloud.size();
        report.width = cloud.width;
        report.height = cloud.height;
        input = "procedural scene (seed " + std::to_string(params.seed) + ", " + std::to_string(params.objects) +
                " objects)";
        timings["generate"] = clock.lap_ms();
    } else {
        cloud = read_cloud(options.input, &report);
        timings["read"] = clock.lap_ms();
    }
    if (!options.downsample.empty()) config.downsample = parse_downsample(options.downsample, "--downsample");

    int single_structure = 0;
    if (mode == FoveationMode::single) {
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
    timings["index"] = clock.lap_ms();
    const FoveatedCloud result = foveate(cloud, index, config, mode, single_structure);
    const double foveate_ms = clock.lap_ms();
    // foveate() times its two phases; mode none has neither (its copy counts as downsampling).
    timings["label"] = result.label_ms;
    timings["downsample"] = mode == FoveationMode::none ? foveate_ms : result.downsample_ms;

    if (!options.output.empty()) {
        if (result.cloud.empty()) {
            throw Error(options.output, "nothing to write: no point of the cloud lies inside any structure");
        }
        write_cloud(options.output, result.cloud, write_options);
    } else if (result.cloud.empty()) {
        warn("no point of the cloud lies inside any structure");
    }
    if (!options.regions_dir.empty()) {
        std::error_code error;
        std::filesystem::create_directories(options.regions_dir, error);
        if (error) throw Error(options.regions_dir, "cannot create directory: " + error.message());
        // Output points are grouped by region, so each region is a run of equal labels.
        for (std::size_t begin = 0; begin < result.cloud.size();) {
            std::size_t end = begin;
            std::vector<std::uint32_t> indices;
            while (end < result.cloud.size() && result.labels[end] == result.labels[begin]) {
                indices.push_back(std::uint32_t(end++));
            }
            const RegionLabel label = result.labels[begin];
            const auto name = "structure" + std::to_string(label.structure) + "_level" + std::to_string(label.level) +
                              ".pcd";
            write_cloud(std::filesystem::path(options.regions_dir) / name, select(result.cloud, indices), write_options);
            begin = end;
        }
    }
    timings["write"] = clock.lap_ms();
    timings["total"] = total_clock.lap_ms();

    nlohmann::ordered_json regions_json = nlohmann::ordered_json::array();
    for (const RegionSummary& region : result.regions) {
        if (mode == FoveationMode::single && region.structure != single_structure) continue;
        regions_json.push_back({{"structure", region.structure},
                                {"level", region.level},
                                {"density", region.density},
                                {"points_before", region.points_before},
                                {"points_after", region.points_after}});
    }
    const std::size_t redundant_removed = mode == FoveationMode::mfpc ? result.redundant_points : 0;
    if (print_table(global)) {
        std::vector<std::pair<std::string, std::string>> rows = {
            {"input", input},
            {"mode", to_string(mode)},
            {"downsample", to_string(config.downsample)},
            {"structures", std::to_string(config.structures.size()) + " (levels m = " + std::to_string(config.levels()) +
                               ")"},
            {"points in", group_digits(report.points_in)},
            {"points finite", group_digits(report.points_finite)},
            {"before downsampling", group_digits(result.points_before_downsampling)},
            {"points out", group_digits(result.cloud.size())},
            {"redundant removed", group_digits(redundant_removed)},
        };
        if (!options.output.empty()) rows.emplace_back("output", options.output);
        print_rows(rows);
        std::cout << "\nstructure  level  density (m)  points before  points after\n";
        for (const auto& region : regions_json) {
            char line[128];
            std::snprintf(line, sizeof line, "%9d  %5d  %11.4f  %13zu  %12zu\n", region["structure"].get<int>(),
                          region["level"].get<int>(), region["density"].get<double>(),
                          region["points_before"].get<std::size_t>(), region["points_after"].get<std::size_t>());
            std::cout << line;
        }
        std::cout << "\ntimings (ms)";
        for (const auto& [key, value] : timings.items()) std::cout << "  " << key << " " << format_fixed(value, 2);
        std::cout << '\n';
    }
    write_json(global, {
        {"input", input},
        {"mode", to_string(mode)},
        {"downsample", to_string(config.downsample)},
        {"structures", config.structures.size()},
        {"levels", config.levels()},
        {"points_in", report.points_in},
        {"points_finite", report.points_finite},
        {"points_before_downsampling", result.points_before_downsampling},
        {"points_out", result.cloud.size()},
        {"redundant_points_removed", redundant_removed},
        {"duplicate_points", mode == FoveationMode::raw ? result.redundant_points : 0},
        {"regions", regions_json},
        {"timings_ms", timings},
        {"threads", tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)},
        {"warnings", warnings},
    });
}

}  // namespace

void add_foveate_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<FoveateOptions>();
    CLI::App* command = app.add_subcommand(
        "foveate", "Foveate a cloud: keep full density in each fovea and less in each outer level (paper Section 4)");
    command->add_option("IN", options->input, "Input cloud (.pcd or .ply)");
    command->add_flag("--procedural", options->procedural,
                      "Use the built-in procedural tabletop scene instead of IN, with one structure per object "
                      "unless --config is given");
    command->add_option("--procedural-seed", options->procedural_seed, "Seed of the procedural scene")
        ->capture_default_str();
    command->add_option("--procedural-objects", options->procedural_objects, "Objects in the procedural scene")
        ->check(CLI::Range(1, 8))
        ->capture_default_str();
    command->add_option("-c,--config", options->config, "Foveation config (JSON; keys in the README)")
        ->type_name("FOVEA.json");
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
