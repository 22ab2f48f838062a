#include "mfpc/simulation/demo.hpp"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <cstdio>

#include <nlohmann/json.hpp>

#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/detail/text_format.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/rendering/png_image.hpp"
#include "mfpc/rendering/renderer.hpp"

namespace mfpc {
namespace {

using detail::format_fixed;
using detail::group_digits;

double elapsed_ms(std::chrono::steady_clock::time_point since)
{
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - since).count();
}

// The model's points are spaced 2 mm: dense enough for verification, the descriptors are taken
// at the working resolution anyway.
constexpr float model_spacing = 0.002f;

}  // namespace

DemoRun run_demo(const DemoParams& params, const std::filesystem::path& directory,
                 const std::function<void(const std::string&)>& progress)
{
    if (!is_builtin_object(params.object))
        throw Error("demo", "'" + params.object + "' is not a built-in object");
    auto tell = [&](const std::string& step) {
        if (progress) progress(step);
    };
    DemoRun run;
    run.params = params;
    run.directory = directory;
    prepare_output_directory(directory);
    auto start = std::chrono::steady_clock::now();
    tell("synthesizing a tabletop scene (seed " + std::to_string(params.seed) + ") and describing the " +
         params.object + " from 16 views");
    ComposeParams compose;
    compose.seed = params.seed;
    compose.objects = params.objects;
    compose.distractors = params.distractors;
    const RecognitionParams recognition;
    run.dataset = make_synthetic_dataset(builtin_scene_shapes(params.object), compose, SensorParams{}, model_spacing,
                                         recognition.model);
    prepare_model_verification(run.dataset.model, recognition);
    write_synthetic_dataset(directory, run.dataset);
    run.synthesize_ms = elapsed_ms(start);

    start = std::chrono::steady_clock::now();
    run.truth = ground_truth_of(run.dataset);
    std::vector<PlacedInstance> instances;
    for (const GroundTruthInstance& instance : run.truth.instances) instances.push_back({0, instance.transform});
    const Model* const models[] = {&run.dataset.model};
    for (const char* name : {"plain", "auto", "oracle"}) {
        tell(std::string("recognizing: ") + name);
        DemoStrategy strategy;
        strategy.name = name;
        if (strategy.name != "plain") {
            PlacementParams placement;
            placement.strategy = strategy.name == "auto" ? PlacementStrategy::segments : PlacementStrategy::oracle;
            strategy.placement = place_foveae(run.dataset.scan.cloud, models, recognition, placement, instances);
        }
        const bool foveated = strategy.placement && !strategy.placement->config.structures.empty();
        const SceneFoveation foveation{foveated ? &strategy.placement->config : nullptr,
                                       foveated ? FoveationMode::mfpc : FoveationMode::none, 0};
        strategy.result = recognize(run.dataset.model, run.dataset.scan.cloud, recognition, foveation);
        strategy.evaluation = evaluate(strategy.result, run.dataset.model, run.truth);
        run.strategies.push_back(std::move(strategy));
    }
    const FoveationConfig& placed = run.strategies[1].placement->config;
    if (!placed.structures.empty()) {
        const std::string text = to_json(placed);
        write_file_atomically(directory / "fovea_auto.json", [&](std::ofstream& out) { out << text; });
    }
    run.recognize_ms = elapsed_ms(start);
    return run;
}

void render_demo(DemoRun& run)
{
    const auto start = std::chrono::steady_clock::now();
    const auto automatic = std::find_if(run.strategies.begin(), run.strategies.end(),
                                        [](const DemoStrategy& s) { return s.name == "auto" && s.placement; });
    if (automatic == run.strategies.end()) throw Error("demo", "no automatically placed run to draw");
    std::vector<RenderOverlay> overlays;
    for (const Instance& instance : automatic->result.instances) {
        RenderOverlay overlay;
        for (const Point& p : run.dataset.model.points) overlay.points.push_back(instance.transform * p);
        overlays.push_back(std::move(overlay));
    }
    run.image = run.directory / "demo.png";
    const FoveationConfig& placed = automatic->placement->config;
    write_png(run.image, render_cloud(run.dataset.scan.cloud, placed.structures.empty() ? nullptr : &placed, overlays,
                                      RenderParams{}));
    run.render_ms = elapsed_ms(start);
}

std::string to_json(const DemoRun& run)
{
    nlohmann::ordered_json strategies = nlohmann::ordered_json::array();
    for (const DemoStrategy& s : run.strategies) {
        const RecognitionCounts& counts = s.result.counts;
        strategies.push_back({{"strategy", s.name},
                              {"scene_points_used", counts.scene_points_used},
                              {"scene_keypoints", counts.scene_keypoints},
                              {"correspondences", counts.correspondences},
                              {"instances_true", s.evaluation.instances_true},
                              {"instances_false", s.evaluation.instances_false},
                              {"instances_missed", s.evaluation.instances_missed},
                              {"correspondence_precision", s.evaluation.correspondence_precision},
                              {"placement", s.placement ? nlohmann::ordered_json::parse(to_json(*s.placement))
                                                        : nlohmann::ordered_json(nullptr)},
                              {"time_ms", s.ms()}});
    }
    const nlohmann::ordered_json json = {
        {"output", run.directory.string()},
        {"seed", run.params.seed},
        {"object", run.params.object},
        {"instances", run.truth.instances.size()},
        {"distractors", run.params.distractors},
        {"scene_points", run.dataset.scan.cloud.size()},
        {"model_points", run.dataset.model.points.size()},
        {"model_keypoints", run.dataset.model.features.size()},
        {"strategies", strategies},
        {"image", run.image.string()},
        {"timings_ms", {{"synthesize", run.synthesize_ms}, {"recognize", run.recognize_ms}, {"render", run.render_ms}}}};
    return json.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + '\n';
}

std::string to_table(const DemoRun& run)
{
    const DemoParams& p = run.params;
    const SensorParams& sensor = run.dataset.sensor;
    std::string out = "scene    " + std::to_string(sensor.width) + "x" + std::to_string(sensor.height) + ", " +
                      std::to_string(p.objects) + " " + p.object + (p.objects == 1 ? "" : "s") + " among " +
                      std::to_string(p.distractors) + " distractors (seed " + std::to_string(p.seed) + "), " +
                      group_digits(run.dataset.scan.cloud.size()) + " points\n" + "model    " +
                      group_digits(run.dataset.model.points.size()) + " points, " +
                      group_digits(run.dataset.model.features.size()) +
                      " keypoints from 16 views (made with the scene, not counted below)\n\n";
    char line[200];
    std::snprintf(line, sizeof line, "%-9s %10s %12s %10s %16s %8s %6s %7s %10s\n", "strategy", "structures",
                  "points kept", "keypoints", "correspondences", "found", "false", "missed", "time (ms)");
    out += line;
    for (const DemoStrategy& s : run.strategies) {
        const RecognitionCounts& counts = s.result.counts;
        std::snprintf(line, sizeof line, "%-9s %10s %12s %10s %16s %5zu/%zu %6zu %7zu %10.1f\n", s.name.c_str(),
                      s.placement ? std::to_string(s.placement->config.structures.size()).c_str() : "-",
                      group_digits(counts.scene_points_used).c_str(), group_digits(counts.scene_keypoints).c_str(),
                      group_digits(counts.correspondences).c_str(), s.evaluation.instances_true,
                      run.truth.instances.size(), s.evaluation.instances_false, s.evaluation.instances_missed,
                      s.ms());
        out += line;
    }
    out += "auto: structures placed from the scene and the model (segments); oracle: placed the same way around "
           "the ground truth's instances; times include placement\n";
    const bool placed = run.strategies.size() > 1 && run.strategies[1].placement &&
                        !run.strategies[1].placement->config.structures.empty();
    out += "\nwrote " + run.directory.string() + "/: scene.pcd scene.gt.json labels.png scene.json fovea.json, " +
           (placed ? "fovea_auto.json (the placed structures), " : "") + "model clouds, " + p.object +
           ".mfpcm, and demo.png (the placed structures, instances found in them in red)\n" + "total " +
           format_fixed((run.synthesize_ms + run.recognize_ms + run.render_ms) / 1000.0, 1) + " s\n";
    return out;
}

}  // namespace mfpc
