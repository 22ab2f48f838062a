#include "mfpc/recognition/experiment.hpp"

#include <algorithm>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/json_check.hpp"
#include "mfpc/core/detail/text_file.hpp"
#include "json_fields.hpp"

namespace mfpc {
namespace {

using nlohmann::json;
using detail::check_keys;
using detail::text_of;

std::filesystem::path beside(const std::filesystem::path& config, const std::string& file)
{
    const std::filesystem::path path(file);
    return path.is_absolute() ? path : config.parent_path() / path;
}

// Adds one recognition's counts into a serial strategy's sums.
void add_counts(RecognitionCounts& sum, const RecognitionCounts& part)
{
    sum.scene_points = part.scene_points;
    sum.scene_points_foveated += part.scene_points_foveated;
    sum.redundant_points += part.redundant_points;
    sum.scene_points_used += part.scene_points_used;
    sum.scene_keypoints += part.scene_keypoints;
    sum.scene_keypoints_invalid += part.scene_keypoints_invalid;
    sum.model_keypoints = part.model_keypoints;
    sum.model_keypoints_invalid = part.model_keypoints_invalid;
    sum.correspondences += part.correspondences;
    sum.instances_before_verification += part.instances_before_verification;
}

void add_timings(RecognitionTimings& sum, const RecognitionTimings& part)
{
    sum.place += part.place;
    sum.foveate += part.foveate;
    sum.normals += part.normals;
    sum.keypoints += part.keypoints;
    sum.lrf += part.lrf;
    sum.descriptors += part.descriptors;
    sum.match += part.match;
    sum.group += part.group;
    sum.verify += part.verify;
    sum.total += part.total;
}

// Appends a recognition's keypoints, correspondences and instances to `into`, so a serial
// strategy is scored as one result.
void append_result(RecognitionResult& into, RecognitionResult&& part)
{
    const auto offset = std::uint32_t(into.scene_features.size());
    Features& features = into.scene_features;
    features.keypoints.insert(features.keypoints.end(), part.scene_features.keypoints.begin(),
                              part.scene_features.keypoints.end());
    features.frames.insert(features.frames.end(), part.scene_features.frames.begin(), part.scene_features.frames.end());
    features.descriptors.insert(features.descriptors.end(), part.scene_features.descriptors.begin(),
                                part.scene_features.descriptors.end());
    for (Correspondence c : part.correspondences) {
        c.scene += offset;
        into.correspondences.push_back(c);
    }
    for (Instance& instance : part.instances) {
        for (Correspondence& c : instance.correspondences) c.scene += offset;
        into.instances.push_back(std::move(instance));
    }
}

}  // namespace

ExperimentConfig read_experiment_config(const std::filesystem::path& path)
{
    const std::string file = path.string();
    const std::string text = read_text_file(path);
    // Duplicate keys, deep nesting and syntax errors, named the way every JSON reader names them;
    // the text is then known to parse.
    check_json_text(text, file);
    const json root = json::parse(text);
    const std::string top = file + ": ";
    check_keys(root, top, {"model", "scene", "ground_truth", "params", "runs", "reference", "strategies"});

    ExperimentConfig config;
    config.model = beside(path, text_of(root, "model", top, true));
    config.scene = beside(path, text_of(root, "scene", top, true));
    config.ground_truth = beside(path, text_of(root, "ground_truth", top, true));
    if (const auto params = root.find("params"); params != root.end()) {
        if (params->is_string()) config.params = read_recognition_params(beside(path, params->get<std::string>()));
        else if (params->is_object()) config.params = parse_recognition_params(params->dump(), top + "params");
        else throw Error(top + "params", "must be a parameters file name or a parameters object");
    }
    if (const auto runs = root.find("runs"); runs != root.end()) {
        if (!runs->is_number_integer() || runs->get<long>() < 1 || runs->get<long>() > 100000)
            throw Error(top + "runs", "must be an integer 1..100000");
        config.runs = int(runs->get<long>());
    }

    const auto strategies = root.find("strategies");
    if (strategies == root.end()) throw Error(top + "strategies", "missing");
    if (!strategies->is_array() || strategies->empty()) throw Error(top + "strategies", "must be a non-empty array");
    std::set<std::string> names;
    for (std::size_t i = 0; i < strategies->size(); ++i) {
        const json& item = (*strategies)[i];
        const std::string where = top + "strategies[" + std::to_string(i) + "].";
        check_keys(item, where.substr(0, where.size() - 1), {"name", "mode", "fovea", "structure", "placement"});
        ExperimentStrategy strategy;
        strategy.name = text_of(item, "name", where, true);
        // Names head table rows, chart labels and progress lines: a control character or a '|'
        // would break them, a '"' the charts' data file.
        if (std::any_of(strategy.name.begin(), strategy.name.end(),
                        [](char c) { return (unsigned char)(c) < 0x20 || c == 0x7f || c == '|' || c == '"'; }))
            throw Error(where + "name", "must not hold control characters, '|' or '\"'");
        if (!names.insert(strategy.name).second) throw Error(where + "name", "'" + strategy.name + "' is used twice");
        const std::string mode = text_of(item, "mode", where, true);
        strategy.serial = mode == "serial";
        strategy.mode = strategy.serial ? FoveationMode::single : parse_foveation_mode(mode, where + "mode");
        const std::string fovea = text_of(item, "fovea", where, strategy.mode != FoveationMode::none);
        if (strategy.mode == FoveationMode::none && !fovea.empty())
            throw Error(where + "fovea", "mode none foveates nothing: remove the fovea or choose a mode");
        const std::string placement = text_of(item, "placement", where, false);
        if (!placement.empty() && fovea != "auto") throw Error(where + "placement", "needs \"fovea\": \"auto\"");
        if (fovea == "auto") {
            if (strategy.mode == FoveationMode::single && !strategy.serial)
                throw Error(where + "fovea", "mode single needs a config file to name its structure");
            strategy.placement =
                parse_placement_strategy(placement.empty() ? "segments" : placement, where + "placement");
        } else if (!fovea.empty()) {
            strategy.fovea_file = beside(path, fovea);
            strategy.fovea = read_foveation_config(strategy.fovea_file);
        }
        if (const auto structure = item.find("structure"); structure != item.end()) {
            if (strategy.mode != FoveationMode::single || strategy.serial)
                throw Error(where + "structure", "only applies to mode single");
            if (!structure->is_number_integer() || structure->get<long>() < 0 ||
                structure->get<long>() >= long(strategy.fovea.structures.size()))
                throw Error(where + "structure", "must name a structure of " + fovea + " (0.." +
                                                     std::to_string(strategy.fovea.structures.size() - 1) + ")");
            strategy.structure = int(structure->get<long>());
        } else if (strategy.mode == FoveationMode::single && !strategy.serial && strategy.fovea.structures.size() > 1) {
            throw Error(where + "structure", "missing: " + fovea + " has " +
                                                 std::to_string(strategy.fovea.structures.size()) + " structures");
        }
        config.strategies.push_back(std::move(strategy));
    }

    const std::string reference = text_of(root, "reference", top, false);
    for (std::size_t i = 0; i < config.strategies.size(); ++i) {
        const bool named = !reference.empty() && config.strategies[i].name == reference;
        const bool first_mfpc = reference.empty() && config.reference < 0 &&
                                config.strategies[i].mode == FoveationMode::mfpc && !config.strategies[i].serial;
        if (named || first_mfpc) config.reference = int(i);
    }
    if (!reference.empty() && config.reference < 0)
        throw Error(top + "reference", "'" + reference + "' names no strategy");
    return config;
}

std::vector<StrategyOutcome> run_experiment(const ExperimentConfig& config, const Model& model,
                                            const PointCloud& scene, const GroundTruth& truth,
                                            const std::function<void(int, int)>& progress)
{
    if (config.runs < 1) throw Error("experiment", "runs must be at least 1");
    const int total = config.runs * int(config.strategies.size());
    int done = 0;
    std::vector<StrategyOutcome> outcomes;
    for (const ExperimentStrategy& strategy : config.strategies) {
        StrategyOutcome outcome;
        outcome.name = strategy.name;
        for (int run = 0; run < config.runs; ++run) {
            RecognitionResult combined;
            RecognitionCounts counts;
            RecognitionTimings timings;
            // A placed strategy finds its structures again on every run: its time is part of the run's.
            FoveationConfig placed;
            if (strategy.placement) {
                PlacementParams params;
                params.strategy = *strategy.placement;
                std::vector<PlacedInstance> instances;
                for (const GroundTruthInstance& instance : truth.instances) instances.push_back({0, instance.transform});
                const Model* const models[] = {&model};
                PlacementTrack track;
                const PlacementResult result = place_foveae(scene, models, config.params, params, instances,
                                                            params.strategy == PlacementStrategy::track ? &track : nullptr);
                placed = result.config;
                timings.place = result.ms;
                timings.total = result.ms;
                if (run == 0) outcome.placement = result;
            }
            const FoveationConfig& fovea = strategy.placement ? placed : strategy.fovea;
            // Nothing placed: the plain pipeline, as the placement's fallback says.
            const bool plain = strategy.mode == FoveationMode::none || fovea.structures.empty();
            const int parts = strategy.serial && !plain ? int(fovea.structures.size()) : 1;
            for (int part = 0; part < parts; ++part) {
                const SceneFoveation foveation{plain ? nullptr : &fovea, plain ? FoveationMode::none : strategy.mode,
                                               strategy.serial ? part : strategy.structure, run == 0};
                RecognitionResult result = recognize(model, scene, config.params, foveation);
                const std::vector<Point>& kept = result.foveated.cloud.points;
                outcome.foveated.points.insert(outcome.foveated.points.end(), kept.begin(), kept.end());
                add_counts(counts, result.counts);
                add_timings(timings, result.timings);
                append_result(combined, std::move(result));
            }
            outcome.timings.push_back(timings);
            outcome.foveated.width = std::uint32_t(outcome.foveated.points.size());
            // The pipeline is deterministic: the first run's counts and scores stand for all.
            if (run == 0) {
                outcome.counts = counts;
                outcome.instances = combined.instances.size();
                outcome.evaluation = evaluate(combined, model, truth);
            }
            if (progress) progress(++done, total);
        }
        outcomes.push_back(std::move(outcome));
    }
    return outcomes;
}

}  // namespace mfpc
