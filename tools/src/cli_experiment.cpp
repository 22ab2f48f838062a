#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

#include <tbb/global_control.h>

#include "cli_commands.hpp"
#include "mfpc/core/atomic_file.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/index/point_index.hpp"
#include "mfpc/kernels/foveate.hpp"
#include "mfpc/recognition/experiment.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/statistics.hpp"
#include "mfpc/tools/png_image.hpp"
#include "mfpc/tools/renderer.hpp"
#include "mfpc/tools/synthetic_scene.hpp"

namespace mfpc::cli {
namespace {

struct ExperimentOptions {
    std::string config;
    std::string output;
    int runs = 0;  // 0: the config's
    bool no_charts = false;
};

// The stages of Figure 12's time chart and of the report, in pipeline order.
struct Stage {
    const char* name;
    double RecognitionTimings::*field;
};
constexpr Stage stages[] = {{"foveate", &RecognitionTimings::foveate},   {"normals", &RecognitionTimings::normals},
                            {"keypoints", &RecognitionTimings::keypoints}, {"lrf", &RecognitionTimings::lrf},
                            {"descriptors", &RecognitionTimings::descriptors}, {"match", &RecognitionTimings::match},
                            {"group", &RecognitionTimings::group},         {"verify", &RecognitionTimings::verify},
                            {"total", &RecognitionTimings::total}};

Summary summarize_stage(const StrategyOutcome& outcome, double RecognitionTimings::*field)
{
    std::vector<double> samples;
    for (const RecognitionTimings& t : outcome.timings) samples.push_back(t.*field);
    return summarize(samples);
}

nlohmann::ordered_json summary_json(const Summary& s)
{
    auto number = [](double v) { return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json(); };
    return {{"runs", s.count},           {"mean", number(s.mean)},       {"variance", number(s.variance)},
            {"std", number(s.standard_deviation)}, {"t", number(s.t_quantile)}, {"ci95_low", number(s.low)},
            {"ci95_high", number(s.high)}, {"median", number(s.median)},  {"min", number(s.min)},
            {"max", number(s.max)}};
}

std::string csv_row(const std::vector<std::string>& cells)
{
    std::string row;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        if (i) row += ',';
        const bool quote = cells[i].find_first_of(",\"\n") != std::string::npos;
        if (!quote) {
            row += cells[i];
            continue;
        }
        row += '"';
        for (char c : cells[i]) row += c == '"' ? std::string("\"\"") : std::string(1, c);
        row += '"';
    }
    return row + '\n';
}

std::string fixed(double value, int decimals) { return std::isfinite(value) ? format_fixed(value, decimals) : "n/a"; }

extern "C" char** environ;

// Runs gnuplot on `script` in `directory`, its stderr into `log` there: spawned directly, with no
// shell, so no file name can become a command. Returns its exit status, or -1 when it could not
// be started or did not exit.
int run_gnuplot(const std::filesystem::path& directory, const char* script, const char* log)
{
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addchdir_np(&actions, directory.c_str());
    posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, 2, log, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    char* argv[] = {const_cast<char*>("gnuplot"), const_cast<char*>(script), nullptr};
    pid_t child = 0;
    const int spawned = posix_spawnp(&child, "gnuplot", &actions, nullptr, argv, environ);
    posix_spawn_file_actions_destroy(&actions);
    if (spawned != 0) return -1;
    int status = 0;
    while (waitpid(child, &status, 0) < 0) {
        if (errno != EINTR) return -1;
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Checked before the runs, so a missing gnuplot is told at once, not after minutes of work.
void require_gnuplot()
{
    if (std::system("command -v gnuplot >/dev/null 2>&1") != 0)
        throw Error("experiment", "the charts need gnuplot: install the Debian package gnuplot-nox "
                                  "(scripts/install-deps.sh does), or pass --no-charts");
}

// The charts (Figures 11 and 12 of the paper, one metric each) with gnuplot: bars per strategy;
// the time chart with the 95% intervals as error bars. gnuplot runs in `directory` and the script
// names only the fixed file names there: the directory's own name (any characters) never enters
// the script, where a quote could end a string and start a gnuplot command.
void write_charts(const std::filesystem::path& directory, const std::vector<StrategyOutcome>& outcomes,
                  const std::vector<Summary>& totals)
{
    const std::filesystem::path data = directory / "charts.dat";
    write_file_atomically(data, [&](std::ofstream& out) {
        out << "# strategy points keypoints correspondences correct precision sensitivity true false time low high\n";
        for (std::size_t i = 0; i < outcomes.size(); ++i) {
            // The config reader refuses '"' and control characters in names, so quoting suffices.
            const StrategyOutcome& o = outcomes[i];
            out << '"' << o.name << "\" " << o.counts.scene_points_used << ' ' << o.counts.scene_keypoints << ' '
                << o.counts.correspondences << ' ' << o.evaluation.correct_correspondences << ' '
                << o.evaluation.correspondence_precision << ' ' << o.evaluation.correspondence_sensitivity << ' '
                << o.evaluation.instances_true << ' ' << o.evaluation.instances_false << ' ' << totals[i].mean << ' '
                << (std::isfinite(totals[i].low) ? totals[i].low : totals[i].mean) << ' '
                << (std::isfinite(totals[i].high) ? totals[i].high : totals[i].mean) << '\n';
        }
    });
    struct Chart {
        const char* file;
        const char* title;
        int column;
    };
    const Chart charts[] = {{"fig11a_points.png", "Scene points after foveation", 2},
                            {"fig11b_keypoints.png", "Scene keypoints", 3},
                            {"fig11c_correspondences.png", "Correspondences", 4},
                            {"fig11d_correct_correspondences.png", "Correct correspondences", 5},
                            {"fig12a_precision.png", "Correspondence precision (Eq. 10)", 6},
                            {"fig12b_sensitivity.png", "Correspondence sensitivity (Eq. 11)", 7},
                            {"fig12c_objects.png", "Objects found: true and false instances", 8},
                            {"fig12d_time.png", "Recognition time (ms), mean and 95% interval", 10}};
    const std::filesystem::path script = directory / "charts.gnuplot";
    write_file_atomically(script, [&](std::ofstream& out) {
        out << "set terminal pngcairo size 800,480 noenhanced font 'sans,10'\n"
               "set style fill solid 0.8 border -1\nset boxwidth 0.6\nset grid ytics\nset yrange [0:*]\n"
               "set xtics rotate by -30 left\nunset key\n";
        for (const Chart& chart : charts) {
            out << "set output '" << chart.file << "'\nset title '" << chart.title << "'\n";
            if (chart.column == 8) {
                out << "set key outside right top\nset boxwidth 0.35\n"
                       "plot 'charts.dat' using ($0-0.18):8:xtic(1) with boxes lc rgb '#2a6db0' title 'true', "
                       "'' using ($0+0.18):9 with boxes lc rgb '#a9c6e8' title 'false'\nunset key\nset boxwidth 0.6\n";
            } else if (chart.column == 10) {
                out << "plot 'charts.dat' using 0:10:xtic(1) with boxes lc rgb '#2a6db0', "
                       "'' using 0:10:11:12 with yerrorbars lc rgb 'black' pt -1\n";
            } else {
                out << "plot 'charts.dat' using 0:" << chart.column << ":xtic(1) with boxes lc rgb '#2a6db0'\n";
            }
        }
    });
    if (run_gnuplot(directory, "charts.gnuplot", "charts.log") != 0)
        throw Error("experiment", "gnuplot failed drawing the charts (see " + (directory / "charts.log").string() + ")");
}

void run_experiment_command(const ExperimentOptions& options, const GlobalOptions& global)
{
    ExperimentConfig config = read_experiment_config(options.config);
    if (options.runs > 0) config.runs = options.runs;
    const std::filesystem::path directory(options.output);
    if (!options.no_charts) require_gnuplot();
    prepare_output_directory(directory);

    Stopwatch clock;
    const bool cached = is_model_cache(config.model);
    const Model model = load_model(config.model, config.params.model, true, options.config);
    const double model_ms = clock.lap_ms();
    const PointCloud scene = read_cloud(config.scene);
    const GroundTruth truth = read_ground_truth(config.ground_truth);
    warn_if_truth_of_another_model(truth.model, cached ? model.source : config.model.string(),
                                   config.ground_truth.string());

    std::size_t current = 0;
    Progress bar;
    const auto outcomes = run_experiment(config, model, scene, truth, [&](int done, int total) {
        current = std::size_t(done - 1) / std::size_t(config.runs);
        if (!global.quiet) bar.draw(std::size_t(done), std::size_t(total), config.strategies[std::min(current, config.strategies.size() - 1)].name);
    });

    std::vector<Summary> totals;
    for (const StrategyOutcome& o : outcomes) totals.push_back(summarize_stage(o, &RecognitionTimings::total));
    const bool has_reference = config.reference >= 0;
    const double reference_mean = has_reference ? totals[std::size_t(config.reference)].mean : 0.0;

    // report.json: everything.
    nlohmann::ordered_json strategies = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < outcomes.size(); ++i) {
        const StrategyOutcome& o = outcomes[i];
        const ExperimentStrategy& s = config.strategies[i];
        nlohmann::ordered_json times;
        for (const Stage& stage : stages) times[stage.name] = summary_json(summarize_stage(o, stage.field));
        nlohmann::ordered_json runs = nlohmann::ordered_json::array();
        for (const RecognitionTimings& t : o.timings) runs.push_back(t.total);
        const auto& c = o.counts;
        const auto& e = o.evaluation;
        strategies.push_back(
            {{"name", o.name},
             {"mode", s.serial ? "serial" : to_string(s.mode)},
             {"fovea", s.fovea_file.string()},
             {"counts",
              {{"scene_points", c.scene_points},
               {"points_before_downsampling", c.scene_points_foveated},
               {"redundant_points", c.redundant_points},
               {"scene_points_used", c.scene_points_used},
               {"scene_keypoints", c.scene_keypoints},
               {"correspondences", c.correspondences}}},
             {"evaluation",
              {{"correct_correspondences", e.correct_correspondences},
               {"possible_correspondences", e.possible_correspondences},
               {"precision", e.correspondence_precision},
               {"sensitivity", e.correspondence_sensitivity},
               {"instances_found", o.instances},
               {"instances_true", e.instances_true},
               {"instances_false", e.instances_false},
               {"instances_missed", e.instances_missed}}},
             {"time_ms", times},
             {"total_ms_per_run", runs},
             {"time_reduction_vs_reference_percent",
              has_reference ? nlohmann::ordered_json(reduction_percent(reference_mean, totals[i].mean))
                            : nlohmann::ordered_json()}});
    }
    const nlohmann::ordered_json report = {
        {"config", options.config},
        {"model", config.model.string()},
        {"scene", config.scene.string()},
        {"ground_truth", config.ground_truth.string()},
        {"runs", config.runs},
        {"threads", tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)},
        {"confidence", 0.95},
        {"interval", "mean ± t(0.975, runs - 1) s / sqrt(runs), Student's t (the paper's 1.96 is the normal quantile)"},
        {"reference", has_reference ? nlohmann::ordered_json(config.strategies[std::size_t(config.reference)].name)
                                    : nlohmann::ordered_json()},
        {"model_preparation_ms", model_ms},
        {"model_cached", cached},
        {"params", nlohmann::ordered_json::parse(to_json(config.params))},
        {"strategies", strategies}};
    write_file_atomically(directory / "report.json", [&](std::ofstream& out) { out << json_text(report); });

    // report.csv: one row per strategy.
    write_file_atomically(directory / "report.csv", [&](std::ofstream& out) {
        out << csv_row({"strategy", "mode", "points_before_downsampling", "redundant_points", "scene_points_used",
                        "keypoints", "correspondences", "correct_correspondences", "precision", "sensitivity",
                        "instances_true", "instances_false", "instances_missed", "runs", "time_mean_ms",
                        "time_variance_ms2", "ci95_low_ms", "ci95_high_ms", "reduction_vs_reference_percent"});
        for (std::size_t i = 0; i < outcomes.size(); ++i) {
            const StrategyOutcome& o = outcomes[i];
            const Summary& t = totals[i];
            out << csv_row({o.name, config.strategies[i].serial ? "serial" : to_string(config.strategies[i].mode),
                            std::to_string(o.counts.scene_points_foveated), std::to_string(o.counts.redundant_points),
                            std::to_string(o.counts.scene_points_used), std::to_string(o.counts.scene_keypoints),
                            std::to_string(o.counts.correspondences),
                            std::to_string(o.evaluation.correct_correspondences),
                            fixed(o.evaluation.correspondence_precision, 4),
                            fixed(o.evaluation.correspondence_sensitivity, 4),
                            std::to_string(o.evaluation.instances_true), std::to_string(o.evaluation.instances_false),
                            std::to_string(o.evaluation.instances_missed), std::to_string(t.count), fixed(t.mean, 3),
                            fixed(t.variance, 3), fixed(t.low, 3), fixed(t.high, 3),
                            has_reference ? fixed(reduction_percent(reference_mean, t.mean), 2) : ""});
        }
    });

    // report.md: Table 7's layout (time, interval, reduction) and the metrics table.
    std::string md = "# Experiment: " + config.scene.filename().string() + "\n\n" + std::to_string(config.runs) +
                     " runs per strategy; times are the scene work in ms (model preparation apart: " +
                     format_fixed(model_ms, 1) + " ms" + (cached ? ", from cache" : "") +
                     "). Intervals: 95%, Student's t with runs - 1 degrees of freedom.\n\n";
    md += "| strategy | mean time (ms) | variance | 95% interval | reduction vs " +
          (has_reference ? config.strategies[std::size_t(config.reference)].name : std::string("-")) + " |\n";
    md += "| --- | ---: | ---: | --- | ---: |\n";
    for (std::size_t i = 0; i < outcomes.size(); ++i) {
        const Summary& t = totals[i];
        md += "| " + outcomes[i].name + " | " + fixed(t.mean, 1) + " | " + fixed(t.variance, 1) + " | [" +
              fixed(t.low, 1) + ", " + fixed(t.high, 1) + "] | " +
              (has_reference ? fixed(reduction_percent(reference_mean, t.mean), 1) + "%" : "-") + " |\n";
    }
    md += "\nMean time per stage (ms):\n\n| strategy |";
    for (const Stage& stage : stages) md += std::string(" ") + stage.name + " |";
    md += "\n| --- |";
    for (std::size_t k = 0; k < std::size(stages); ++k) md += " ---: |";
    md += "\n";
    for (const StrategyOutcome& o : outcomes) {
        md += "| " + o.name + " |";
        for (const Stage& stage : stages) md += " " + fixed(summarize_stage(o, stage.field).mean, 1) + " |";
        md += "\n";
    }
    md += "\n| strategy | points (before downsampling) | points used | keypoints | correspondences | correct | "
          "precision | sensitivity | true | false | missed |\n| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | "
          "---: | ---: | ---: |\n";
    for (const StrategyOutcome& o : outcomes) {
        md += "| " + o.name + " | " + group_digits(o.counts.scene_points_foveated) + " | " +
              group_digits(o.counts.scene_points_used) + " | " + group_digits(o.counts.scene_keypoints) + " | " +
              group_digits(o.counts.correspondences) + " | " + group_digits(o.evaluation.correct_correspondences) +
              " | " + fixed(o.evaluation.correspondence_precision, 3) + " | " +
              fixed(o.evaluation.correspondence_sensitivity, 3) + " | " + std::to_string(o.evaluation.instances_true) +
              " | " + std::to_string(o.evaluation.instances_false) + " | " +
              std::to_string(o.evaluation.instances_missed) + " |\n";
    }
    write_file_atomically(directory / "report.md", [&](std::ofstream& out) { out << md; });

    // A picture of each strategy's foveated scene: the points it kept, coloured by region, in the
    // sensor's view (a serial strategy's single runs drawn together).
    const PointIndex index(scene);
    for (std::size_t i = 0; i < config.strategies.size(); ++i) {
        const ExperimentStrategy& s = config.strategies[i];
        const std::filesystem::path image = directory / ("strategy_" + std::to_string(i + 1) + ".png");
        if (s.mode == FoveationMode::none) {
            write_png(image, render_cloud(scene, nullptr, {}, RenderParams{}));
            continue;
        }
        PointCloud kept;
        const int parts = s.serial ? int(s.fovea.structures.size()) : 1;
        for (int part = 0; part < parts; ++part) {
            const FoveatedCloud foveated = foveate(scene, index, s.fovea, s.mode, s.serial ? part : s.structure);
            kept.points.insert(kept.points.end(), foveated.cloud.points.begin(), foveated.cloud.points.end());
        }
        kept.width = std::uint32_t(kept.points.size());
        RenderParams params;
        params.width = scene.width;  // the sensor's view and size, though the kept points are no longer a grid
        params.height = scene.height;
        write_png(image, render_cloud(kept, &s.fovea, {}, params));
    }
    if (!options.no_charts) write_charts(directory, outcomes, totals);

    if (print_table(global)) std::cout << md;
    write_json(global, report);
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
