#include <filesystem>
#include <iostream>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/recognition/experiment.hpp"
#include "mfpc/recognition/experiment_report.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/rendering/charts.hpp"
#include "mfpc/rendering/png_image.hpp"
#include "mfpc/rendering/renderer.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"

namespace mfpc::cli {
namespace {

struct ExperimentOptions {
    std::string config;
    std::string output;
    int runs = 0;  // 0: the config's
    bool no_charts = false;
};

void run_experiment_command(const ExperimentOptions& options, const GlobalOptions& global)
{
    ExperimentReport report;
    report.config_file = options.config;
    report.config = read_experiment_config(options.config);
    ExperimentConfig& config = report.config;
    if (options.runs > 0) config.runs = options.runs;
    const std::filesystem::path directory(options.output);
    if (!options.no_charts) require_gnuplot();
    prepare_output_directory(directory);

    Stopwatch clock;
    report.model_cached = is_model_cache(config.model);
    Model model = load_model(config.model, config.params.model, true, options.config);
    prepare_model_verification(model, config.params);
    report.model_ms = clock.lap_ms();
    const PointCloud scene = read_cloud(config.scene);
    const GroundTruth truth = read_ground_truth(config.ground_truth);
    warn_if_truth_of_another_model(truth.model, report.model_cached ? model.source : config.model.string(),
                                   config.ground_truth.string());

    Progress bar;
    report.outcomes = run_experiment(config, model, scene, truth, [&](int done, int total) {
        const std::size_t current = std::size_t(done - 1) / std::size_t(config.runs);
        if (!global.quiet)
            bar.draw(std::size_t(done), std::size_t(total),
                     config.strategies[std::min(current, config.strategies.size() - 1)].name);
    });
    report.threads = active_threads();

    const std::string markdown = to_markdown(report);
    // The reports and pictures all or none (the charts, drawn by gnuplot from them, come after).
    StagedFiles files;
    files.stage(directory / "report.json", to_json(report));
    files.stage(directory / "report.csv", to_csv(report));
    files.stage(directory / "report.md", markdown);
    const auto stage_png = [&](const std::filesystem::path& path, const RgbImage& image) {
        files.stage(path, png_file_bytes(image, path.string()));
    };

    // A picture of each strategy's foveated scene: the points it kept, coloured by region, in the
    // sensor's view (a serial strategy's single runs drawn together).
    for (std::size_t i = 0; i < config.strategies.size(); ++i) {
        const ExperimentStrategy& s = config.strategies[i];
        const std::filesystem::path image = directory / ("strategy_" + std::to_string(i + 1) + ".png");
        if (s.mode == FoveationMode::none) {
            stage_png(image, render_cloud(scene, nullptr, {}, RenderParams{}));
            continue;
        }
        RenderParams params;
        params.width = scene.width;  // the sensor's view and size, though the kept points are no longer a grid
        params.height = scene.height;
        // A placed strategy is drawn with the structures its first run placed.
        const std::optional<PlacementResult>& placed = report.outcomes[i].placement;
        const FoveationConfig* fovea = placed ? &placed->config : &s.fovea;
        if (report.outcomes[i].foveated.empty()) {
            stage_png(image, render_cloud(scene, nullptr, {}, RenderParams{}));  // nothing placed: it ran plain
            continue;
        }
        stage_png(image, render_cloud(report.outcomes[i].foveated, fovea, {}, params));
    }
    files.commit();
    if (!options.no_charts) write_experiment_charts(directory, to_chart_data(report));

    if (print_table(global)) std::cout << markdown;
    write_json(global, to_json(report));
}

}  // namespace

void add_experiment_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<ExperimentOptions>();
    CLI::App* command = app.add_subcommand(
        "experiment", "The paper's comparison of foveation strategies (Sections 6-7): N runs each, ground-truth "
                      "metrics, 95% intervals, report and charts");
    command->add_option("--config", options->config, "Experiment config (JSON; keys in the README)")
        ->type_name("EXPERIMENT.json")
        ->required();
    command->add_option("-o,--output", options->output, "Report directory")->type_name("DIR")->required();
    command->add_option("--runs", options->runs, "Runs per strategy (default: the config's, else 15)")
        ->check(CLI::Range(1, 100000));
    command->add_flag("--no-charts", options->no_charts, "Skip the gnuplot charts");
    command->footer("Writes report.json, report.csv, report.md, strategy_K.png (each strategy's foveation) and the\n"
                    "charts fig11a..fig12d (*.png, drawn with gnuplot) into DIR.");
    command->callback([options, &global] { run_experiment_command(*options, global); });
}

}  // namespace mfpc::cli
