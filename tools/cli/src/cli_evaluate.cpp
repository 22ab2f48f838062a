#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/recognition/dataset.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/recognition/placement.hpp"

namespace mfpc::cli {
namespace {

struct EvaluateOptions {
    std::string dataset;
    std::string data_dir;
    std::string params;
    std::string runs = "both";
    float min_visible = 0.5f;
    std::string csv;
    std::string placements;
    bool explain = false;
};

void run_evaluate(const EvaluateOptions& options, const GlobalOptions& global)
{
    const Dataset dataset = read_dataset(options.dataset, options.data_dir);
    const RecognitionParams params = options.params.empty() ? RecognitionParams{} : read_recognition_params(options.params);
    DatasetOptions run;
    run.plain = options.runs != "fovea";
    run.foveated = options.runs != "plain";
    run.min_visible_fraction = options.min_visible;
    run.explain = options.explain;
    for (const std::string& name : split_list(options.placements)) {
        try {
            run.placements.push_back(parse_placement_strategy(name, "--placement"));
        } catch (const Error&) {
            throw CLI::ValidationError("--placement", "'" + name + "' is not one of segments, coarse, grid, track, oracle");
        }
        if (std::count(run.placements.begin(), run.placements.end(), run.placements.back()) > 1)
            throw CLI::ValidationError("--placement", "'" + name + "' given twice");
    }
    Progress bar;
    const DatasetReport report =
        evaluate_dataset(dataset, params, !options.params.empty(), options.params, run,
                         [&](std::size_t done, std::size_t total, const std::string& scene) {
                             if (!global.quiet) bar.draw(done, total, scene);
                         });
    for (const ModelOutcome& model : report.models)
        if (!model.error.empty()) warn("model " + model.name + ": " + model.error);
    if (!options.csv.empty())
        write_file_atomically(options.csv, [&](std::ofstream& out) { out << to_csv(report); });
    if (print_table(global)) std::cout << to_table(report);
    write_json(global, nlohmann::ordered_json::parse(to_json(report)));
}

}  // namespace

void add_evaluate_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<EvaluateOptions>();
    CLI::App* command = app.add_subcommand(
        "evaluate", "Run recognition over a benchmark set (models, scenes with ground truth, negative scenes) and "
                    "report found / false / missed, correspondence precision and sensitivity, time and peak memory");
    command->add_option("--dataset", options->dataset, "Dataset manifest (JSON; keys in the README)")
        ->type_name("SET.json")
        ->required();
    command->add_option("--data-dir", options->data_dir,
                        "Directory the manifest's model, cloud and ground-truth files are relative to "
                        "(default: the manifest's data_dir)")
        ->type_name("DIR");
    command->add_option("-p,--params", options->params,
                        "Recognition parameters (JSON; keys in the README; default: the built-in set)")
        ->type_name("PARAMS.json");
    command->add_option("--runs", options->runs,
                        "plain: every scene without foveation; fovea: the scenes with a fovea config, foveated; "
                        "both (default)")
        ->check(CLI::IsMember({"plain", "fovea", "both"}));
    command->add_option("--min-visible", options->min_visible,
                        "Recall is reported for the instances with at least this share of their surface visible "
                        "(default 0.5)")
        ->check(CLI::Range(0.0f, 1.0f));
    command->add_option("--placement", options->placements,
                        "Also run every scene foveated by these automatic placements, comma-separated: segments, "
                        "coarse, grid, track (the scenes of a group as the frames of a sequence), oracle (from the "
                        "ground truth: what placement would give knowing where the objects are)")
        ->type_name("LIST");
    command->add_option("--csv", options->csv, "Also write one CSV row per scene run")->type_name("PATH");
    command->add_flag("--explain", options->explain,
                      "Say where each missed instance was lost (no correct correspondence, no hypothesis near it, "
                      "or the verification test that refused it): in the table's note and the JSON; each scene "
                      "with a miss runs a second time");
    command->callback([options, &global] { run_evaluate(*options, global); });
}

}  // namespace mfpc::cli
