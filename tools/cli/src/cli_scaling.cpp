#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <tbb/info.h>

#include "cli_commands.hpp"
#include "mfpc/batch/scaling.hpp"
#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/rendering/charts.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"

namespace mfpc::cli {
namespace {

struct ScalingOptions {
    std::vector<std::string> models;
    std::vector<std::string> scenes;
    std::string threads;  // "1,2,4"; empty: 1 up to the cores present, doubling
    std::string output;
    std::string params;
    BatchFoveaOptions fovea;
    bool no_charts = false;
};

void run_scaling_command(const ScalingOptions& options, const GlobalOptions& global)
{
    std::vector<int> threads;
    for (const std::string& item : split_list(options.threads)) {
        if (item.size() > 4 || item.find_first_not_of("0123456789") != std::string::npos || std::stoi(item) < 1)
            throw CLI::ValidationError("--threads", "'" + item + "' is not a thread count 1..4096");
        threads.push_back(std::stoi(item));
    }
    if (threads.empty()) threads = default_thread_counts(tbb::info::default_concurrency());
    if (!options.no_charts) require_gnuplot();
    BatchJob job;
    FoveationConfig fovea;
    apply_batch_fovea_options(options.fovea, job, fovea);
    job.scenes = list_scenes(options.scenes);
    job.params = load_params(options.params);
    job.models = load_batch_models(options.models, job.params, options.params);
    const std::filesystem::path directory(options.output);
    prepare_output_directory(directory);
    const std::vector<ScalingPoint> points = run_scaling(job, threads, directory, [&](int t) {
        if (!global.quiet) std::cerr << "scaling: " << job.scenes.size() << " scenes at " << t << " threads\n";
    });
    const std::string csv = to_csv(points);
    write_file_atomically(directory / "scaling.csv", [&](std::ofstream& out) { out << csv; });
    write_file_atomically(directory / "scaling.json", [&](std::ofstream& out) { out << to_json(points); });
    if (!options.no_charts) write_scaling_charts(directory);
    if (print_table(global)) std::cout << csv;
    write_json(global, to_json(points));
}

}  // namespace

void add_scaling_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<ScalingOptions>();
    CLI::App* command = app.add_subcommand(
        "scaling", "A scaling study: the batch at several thread counts; throughput, speed-up and efficiency "
                   "per stage and end to end");
    command->add_option("--model", options->models, "Model cloud or cache; repeat for several")
        ->type_name("MODEL")
        ->required();
    command->add_option("--scenes", options->scenes, "Scenes, as `mfpc batch --scenes` takes them; repeat to add")
        ->type_name("DIR|LIST|GLOB")
        ->required();
    command->add_option("--threads", options->threads,
                        "Comma-separated thread counts (default: 1 up to the cores present, doubling)")
        ->type_name("1,2,4,...");
    command->add_option("-o,--output", options->output, "Report directory")->type_name("DIR")->required();
    command->add_option("-p,--params", options->params, "Recognition parameters (JSON; keys in the README)")
        ->type_name("PARAMS.json");
    add_batch_fovea_options(command, options->fovea);
    command->add_flag("--no-charts", options->no_charts, "Skip the gnuplot charts");
    command->footer("Writes into DIR: threads_N.jsonl (each count's records), scaling.csv, scaling.json and the\n"
                    "charts scaling_throughput.png, scaling_speedup.png, scaling_efficiency.png (gnuplot).\n"
                    "Each count is capped by the global --threads (default: every core).");
    command->callback([options, &global] { run_scaling_command(*options, global); });
}

}  // namespace mfpc::cli
