#include <filesystem>
#include <iostream>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "mfpc/tools/png_image.hpp"
#include "mfpc/tools/renderer.hpp"
#include "mfpc/tools/synthetic_scene.hpp"

namespace mfpc::cli {
namespace {

struct DemoOptions {
    std::uint32_t seed = 1;
    std::uint32_t objects = 3;
    std::uint32_t distractors = 3;
    std::string object = "carton";
    std::string output = "out/demo";
};

struct StrategyRun {
    const char* name;
    RecognitionResult result;
    Evaluation evaluation;
};

// The demo's progress goes to stderr, so stdout keeps only the table (and --json - stays clean).
void progress(const GlobalOptions& global, const std::string& step)
{
    if (!global.quiet) std::cerr << "demo: " << step << '\n';
}

void run_demo(const DemoOptions& options, const GlobalOptions& global)
{
    if (!is_builtin_object(options.object))
        throw CLI::ValidationError("--object", "'" + options.object + "' is not a built-in object");
    const std::filesystem::path directory(options.output);
    prepare_output_directory(directory);
    Stopwatch clock;
    progress(global, "synthesizing a tabletop scene (seed " + std::to_string(options.seed) +
                         ") and describing the " + options.object + " from 16 views");
    std::vector<SceneShape> shapes = builtin_scene_shapes(options.object);
    ComposeParams compose;
    compose.seed = options.seed;
    compose.objects = options.objects;
    compose.distractors = options.distractors;
    const SensorParams sensor;
    const RecognitionParams params;
    const SyntheticDataset dataset = make_synthetic_dataset(std::move(shapes), compose, sensor, 0.002f, params.model);
    write_synthetic_dataset(directory, dataset);
    const double synth_ms = clock.lap_ms();
    const Model& model = dataset.model;

    const GroundTruth truth = ground_truth_of(dataset);

    std::vector<StrategyRun> runs;
    for (const char* name : {"plain", "mfpc"}) {
        progress(global, std::string("recognizing: ") + name);
        const bool foveated = std::string(name) == "mfpc";
        SceneFoveation foveation;
        if (foveated) foveation = {&dataset.fovea, FoveationMode::mfpc, 0};
        StrategyRun run{name, recognize(model, dataset.scan.cloud, params, foveation), {}};
        run.evaluation = evaluate(run.result, model, truth);
        runs.push_back(std::move(run));
    }
    const double recognize_ms = clock.lap_ms();

    progress(global, "rendering");
    const StrategyRun& shown = runs.back();
    std::vector<RenderOverlay> overlays;
    for (const Instance& instance : shown.result.instances) {
        RenderOverlay overlay;
        for (const Point& p : model.points) overlay.points.push_back(instance.transform * p);
        overlays.push_back(std::move(overlay));
    }
    const std::filesystem::path image = directory / "demo.png";
    write_png(image, render_cloud(dataset.scan.cloud, &dataset.fovea, overlays, RenderParams{}));
    const double render_ms = clock.lap_ms();

    nlohmann::ordered_json strategies = nlohmann::ordered_json::array();
    for (const StrategyRun& run : runs) {
        const RecognitionCounts& counts = run.result.counts;
        strategies.push_back({{"strategy", run.name},
                              {"scene_points_used", counts.scene_points_used},
                              {"scene_keypoints", counts.scene_keypoints},
                              {"correspondences", counts.correspondences},
                              {"instances_true", run.evaluation.instances_true},
                              {"instances_false", run.evaluation.instances_false},
                              {"instances_missed", run.evaluation.instances_missed},
                              {"correspondence_precision", run.evaluation.correspondence_precision},
                              {"time_ms", run.result.timings.total}});
    }
    if (print_table(global)) {
        std::cout << "scene    " << sensor.width << "x" << sensor.height << ", " << options.objects << " "
                  << options.object << (options.objects == 1 ? "" : "s") << " among " << options.distractors
                  << " distractors (seed " << options.seed << "), " << group_digits(dataset.scan.cloud.size())
                  << " points\n"
                  << "model    " << group_digits(model.points.size()) << " points, " << group_digits(model.features.size())
                  << " keypoints from 16 views (made with the scene, not counted below)\n\n";
        char line[200];
        std::snprintf(line, sizeof line, "%-9s %12s %10s %16s %8s %6s %7s %10s\n", "strategy", "points kept",
                      "keypoints", "correspondences", "found", "false", "missed", "time (ms)");
        std::cout << line;
        for (const StrategyRun& run : runs) {
            const RecognitionCounts& counts = run.result.counts;
            std::snprintf(line, sizeof line, "%-9s %12s %10s %16s %5zu/%zu %6zu %7zu %10.1f\n", run.name,
                          group_digits(counts.scene_points_used).c_str(), group_digits(counts.scene_keypoints).c_str(),
                          group_digits(counts.correspondences).c_str(), run.evaluation.instances_true, truth.instances.size(),
                          run.evaluation.instances_false, run.evaluation.instances_missed, run.result.timings.total);
            std::cout << line;
        }
        std::cout << "\nwrote " << directory.string() << "/: scene.pcd scene.gt.json labels.png scene.json fovea.json, "
                  << "model clouds, " << options.object << ".mfpcm, and demo.png (mfpc foveation, instances in red)\n"
                  << "total " << format_fixed((synth_ms + recognize_ms + render_ms) / 1000.0, 1) << " s\n";
    }
    write_json(global, {{"output", directory.string()},
                        {"seed", options.seed},
                        {"object", options.object},
                        {"instances", truth.instances.size()},
                        {"distractors", options.distractors},
                        {"scene_points", dataset.scan.cloud.size()},
                        {"model_points", model.points.size()},
                        {"model_keypoints", model.features.size()},
                        {"strategies", strategies},
                        {"image", image.string()},
                        {"timings_ms",
                         {{"synthesize", synth_ms}, {"recognize", recognize_ms}, {"render", render_ms}}}});
}

}  // namespace

void add_demo_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<DemoOptions>();
    CLI::App* command = app.add_subcommand(
        "demo", "No input needed: synthesize a tabletop scene, recognize its instances with and without "
                "multifoveation, print the comparison and render a picture");
    command->footer("Writes the synthetic dataset (as `mfpc synth`) and demo.png into DIR.");
    command->add_option("-o,--output", options->output, "Output directory")->type_name("DIR")->capture_default_str();
    command->add_option("--seed", options->seed, "Seed of the scene")->capture_default_str();
    command->add_option("--objects", options->objects, "Instances to find")->check(CLI::Range(1, 20))->capture_default_str();
    command->add_option("--distractors", options->distractors, "Other objects")->check(CLI::Range(0, 20))->capture_default_str();
    command->add_option("--object", options->object, "Built-in object to find: carton, bottle, mug, box, jug")
        ->capture_default_str();
    command->callback([options, &global] { run_demo(*options, global); });
}

}  // namespace mfpc::cli
