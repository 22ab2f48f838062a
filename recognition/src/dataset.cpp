#include "mfpc/recognition/dataset.hpp"

#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/detail/text_format.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/detail/json_check.hpp"
#include "mfpc/core/peak_memory.hpp"
#include "mfpc/core/detail/text_file.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "mfpc/recognition/described_scene.hpp"
#include "mfpc/recognition/diagnosis.hpp"
#include "json_fields.hpp"

namespace mfpc {
namespace {

using detail::csv_field;
using detail::format_fixed;
using detail::group_digits;

using nlohmann::json;
using nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;
using detail::check_keys;
using detail::text_of;

double elapsed_ms(Clock::time_point since)
{
    return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

std::filesystem::path under(const std::filesystem::path& directory, const std::string& file)
{
    const std::filesystem::path path(file);
    return path.is_absolute() ? path : directory / path;
}

}  // namespace

Dataset read_dataset(const std::filesystem::path& path, const std::filesystem::path& data_dir)
{
    const std::string file = path.string();
    const std::string text = read_text_file(path);
    check_json_text(text, file);
    const json root = json::parse(text);
    const std::string top = file + ": ";
    check_keys(root, top, {"name", "data_dir", "models", "scenes"});

    Dataset dataset;
    dataset.source = path;
    dataset.name = text_of(root, "name", top, false);
    if (dataset.name.empty()) dataset.name = path.stem().string();
    const std::filesystem::path manifest_dir = path.parent_path();
    const std::string data_text = text_of(root, "data_dir", top, false);
    const std::filesystem::path data = !data_dir.empty() ? data_dir : under(manifest_dir, data_text);

    const auto models = root.find("models");
    if (models == root.end()) throw Error(top + "models", "missing");
    if (!models->is_array() || models->empty()) throw Error(top + "models", "must be a non-empty array");
    std::set<std::string> model_names;
    for (std::size_t i = 0; i < models->size(); ++i) {
        const std::string where = top + "models[" + std::to_string(i) + "].";
        check_keys((*models)[i], where.substr(0, where.size() - 1), {"name", "file"});
        DatasetModel model;
        const std::string model_file = text_of((*models)[i], "file", where, true);
        model.file = under(data, model_file);
        model.name = text_of((*models)[i], "name", where, false);
        if (model.name.empty()) model.name = std::filesystem::path(model_file).stem().string();
        if (!model_names.insert(model.name).second) throw Error(where + "name", "'" + model.name + "' names two models");
        dataset.models.push_back(model);
    }

    const auto scenes = root.find("scenes");
    if (scenes == root.end()) throw Error(top + "scenes", "missing");
    if (!scenes->is_array() || scenes->empty()) throw Error(top + "scenes", "must be a non-empty array");
    std::set<std::string> scene_names;
    for (std::size_t i = 0; i < scenes->size(); ++i) {
        const json& entry = (*scenes)[i];
        const std::string where = top + "scenes[" + std::to_string(i) + "].";
        check_keys(entry, where.substr(0, where.size() - 1),
                   {"name", "model", "cloud", "ground_truth", "negative", "fovea", "group"});
        DatasetScene scene;
        const std::string cloud = text_of(entry, "cloud", where, true);
        scene.cloud = under(data, cloud);
        scene.name = text_of(entry, "name", where, false);
        if (scene.name.empty()) scene.name = std::filesystem::path(cloud).stem().string();
        if (!scene_names.insert(scene.name).second) throw Error(where + "name", "'" + scene.name + "' names two scenes");
        scene.model = text_of(entry, "model", where, false);
        if (scene.model.empty()) {
            if (dataset.models.size() != 1)
                throw Error(where + "model", "missing: the set has " + std::to_string(dataset.models.size()) + " models");
            scene.model = dataset.models[0].name;
        } else if (!model_names.count(scene.model)) {
            throw Error(where + "model", "'" + scene.model + "' is not the name of a model of the set");
        }
        const std::string truth = text_of(entry, "ground_truth", where, false);
        bool negative = false;
        if (const auto it = entry.find("negative"); it != entry.end()) {
            if (!it->is_boolean()) throw Error(where + "negative", "must be true or false");
            negative = it->get<bool>();
        }
        // Said both ways or neither: a positive scene that lost its ground truth must not pass as
        // a negative one.
        if (negative == !truth.empty())
            throw Error(where.substr(0, where.size() - 1),
                        truth.empty() ? "needs \"ground_truth\", or \"negative\": true for a scene with no object"
                                      : "has a ground truth and \"negative\": true");
        if (!truth.empty()) scene.ground_truth = under(data, truth);
        const std::string fovea = text_of(entry, "fovea", where, false);
        if (!fovea.empty()) scene.fovea = under(manifest_dir, fovea);
        scene.group = text_of(entry, "group", where, false);
        dataset.scenes.push_back(scene);
    }
    return dataset;
}

void check_dataset_files(const Dataset& dataset)
{
    const std::string top = dataset.source.string() + ": ";
    auto require = [&](const std::filesystem::path& file, const std::string& entry) {
        std::error_code error;
        if (!file.empty() && !std::filesystem::exists(file, error))
            throw Error(top + entry, "no such file: " + file.string());
    };
    for (std::size_t i = 0; i < dataset.models.size(); ++i)
        require(dataset.models[i].file, "models[" + std::to_string(i) + "].file");
    for (std::size_t i = 0; i < dataset.scenes.size(); ++i) {
        const std::string entry = "scenes[" + std::to_string(i) + "].";
        require(dataset.scenes[i].cloud, entry + "cloud");
        require(dataset.scenes[i].ground_truth, entry + "ground_truth");
        require(dataset.scenes[i].fovea, entry + "fovea");
    }
}

namespace {

// How one scene runs: plain, with the manifest's fovea, or placed by a strategy (track carrying
// its state along the scene's group).
struct SceneRun {
    bool fovea = false;
    std::optional<PlacementStrategy> placement;
    PlacementTrack* track = nullptr;
    std::string name() const { return placement ? to_string(*placement) : fovea ? "fovea" : "plain"; }
};

// One scene run one way; every failure of this scene's own inputs becomes its outcome's error.
SceneOutcome run_scene(const DatasetScene& scene, const Model* model, const std::string& model_error,
                       const RecognitionParams& params, const SceneRun& run, const DatasetOptions& options)
{
    SceneOutcome out;
    out.scene = scene.name;
    out.model = scene.model;
    out.strategy = run.name();
    out.group = scene.group;
    out.negative = scene.ground_truth.empty();
    try {
        if (!model) throw Error(scene.model, model_error);
        out.peak_memory_reset = reset_peak_memory();
        GroundTruth truth;
        if (!out.negative) truth = read_ground_truth(scene.ground_truth);
        for (const GroundTruthInstance& instance : truth.instances)
            out.truth.push_back({instance.object, instance.visible_fraction, false, {}});
        FoveationConfig config;
        if (run.fovea) config = read_foveation_config(scene.fovea);
        auto start = Clock::now();
        const PointCloud cloud = read_cloud(scene.cloud);
        out.read_ms = elapsed_ms(start);
        out.scene_points = cloud.size();
        bool nothing_placed = false;
        if (run.placement) {
            PlacementParams placement = options.placement;
            placement.strategy = *run.placement;
            std::vector<PlacedInstance> placed;
            for (const GroundTruthInstance& instance : truth.instances) placed.push_back({0, instance.transform});
            const Model* const models[] = {model};
            PlacementResult result = place_foveae(cloud, models, params, placement, placed, run.track);
            out.placement_ms = result.ms;
            out.fallback = result.fallback;
            config = std::move(result.config);
            // The oracle knows there is nothing to find; the others fall back to the plain pipeline.
            nothing_placed = config.structures.empty() && *run.placement == PlacementStrategy::oracle;
            if (nothing_placed) out.fallback = "oracle: no instance to place a structure around, nothing described";
        }
        out.structures = config.structures.size();
        const SceneFoveation foveation{config.structures.empty() ? nullptr : &config, FoveationMode::mfpc, 0};
        // Explaining keeps the run's description and hypotheses for the diagnosis (it re-verifies
        // with the evidence, so it needs refinement or verification on).
        const bool explaining = options.explain && !nothing_placed && (params.refine.enabled || params.verify.enabled);
        RecognitionTrace trace;
        RecognitionResult result;
        if (explaining) result = recognize_traced(*model, cloud, params, foveation, trace);
        else if (!nothing_placed) result = recognize(*model, cloud, params, foveation);
        if (run.track) {
            std::vector<PlacedInstance> found;
            for (const Instance& instance : result.instances) found.push_back({0, instance.transform});
            const Model* const models[] = {model};
            track_update(*run.track, models, found, options.placement.track_refresh);
        }
        out.peak_memory = peak_memory_bytes();
        out.instances = result.instances.size();
        out.evaluation = evaluate(result, *model, truth, options.evaluation);
        for (const int match : out.evaluation.instance_match)
            if (match >= 0) out.truth.at(std::size_t(match)).found = true;
        if (explaining && out.evaluation.instances_missed > 0) {
            const std::vector<TruthDiagnosis> diagnoses =
                diagnose_truth(*trace.described, *model, result, trace.hypotheses, truth, options.evaluation);
            for (std::size_t t = 0; t < diagnoses.size(); ++t)
                if (!out.truth[t].found && diagnoses[t].stage != LossStage::found) {
                    out.truth[t].lost = to_string(diagnoses[t].stage);
                    out.truth[t].correct_correspondences = static_cast<long long>(diagnoses[t].correct_correspondences);
                }
        }
        out.scene_keypoints = result.counts.scene_keypoints;
        out.correspondences = result.counts.correspondences;
        out.points_used = result.counts.scene_points_used;
        out.timings = result.timings;
        out.scene_ms = out.placement_ms + result.timings.total;
    } catch (const std::bad_alloc&) {
        out.error = "out of memory";
    } catch (const std::exception& error) {
        out.error = error.what();
    }
    return out;
}

// Whether an instance counts for recall: seen at least min_visible, or not said.
bool counts_as_visible(const TruthOutcome& t, float min_visible)
{
    return !(t.visible_fraction >= 0 && t.visible_fraction < min_visible);
}

void add(DatasetTotals& totals, const SceneOutcome& scene, float min_visible)
{
    ++totals.scenes;
    if (!scene.error.empty()) {
        // A scene that could not run found none of its objects (those known: a ground truth that
        // could not be read leaves none to count).
        ++totals.failed;
        totals.truth += scene.truth.size();
        totals.instances_missed += scene.truth.size();
        for (const TruthOutcome& t : scene.truth) totals.visible += counts_as_visible(t, min_visible);
        return;
    }
    const Evaluation& e = scene.evaluation;
    totals.instances_true += e.instances_true;
    totals.instances_true_by_surface += e.instances_true_by_surface;
    totals.instances_false += e.instances_false;
    totals.instances_missed += e.instances_missed;
    if (scene.negative) totals.false_on_negatives += e.instances_false;
    totals.truth += scene.truth.size();
    for (const TruthOutcome& t : scene.truth) {
        if (!counts_as_visible(t, min_visible)) continue;
        ++totals.visible;
        totals.visible_found += t.found;
    }
    totals.correspondences += scene.correspondences;
    totals.correct_correspondences += e.correct_correspondences;
    totals.possible_correspondences += e.possible_correspondences;
    totals.sensitivity_sum += e.correspondence_sensitivity * double(e.possible_correspondences);
    totals.scene_ms.push_back(scene.scene_ms);
    totals.placement_ms.push_back(scene.placement_ms);
    totals.structures += scene.structures;
    totals.points_used += scene.points_used;
    totals.fallbacks += !scene.fallback.empty();
    totals.peak_memory = std::max(totals.peak_memory, scene.peak_memory);
}

double median_of(std::vector<double> values)
{
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    const std::size_t n = values.size();
    return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// The placements that ran and their shared parameters (each run sets its own strategy).
ordered_json placement_json(const DatasetOptions& options)
{
    if (options.placements.empty()) return nullptr;
    ordered_json params = ordered_json::parse(to_json(options.placement));
    params.erase("strategy");
    ordered_json strategies = ordered_json::array();
    for (const PlacementStrategy strategy : options.placements) strategies.push_back(to_string(strategy));
    return {{"strategies", strategies}, {"params", params}};
}

std::string recall_text(double recall) { return std::isnan(recall) ? "-" : format_fixed(recall, 3); }

std::string mebibytes(std::size_t bytes) { return format_fixed(double(bytes) / (1024.0 * 1024.0), 0); }

ordered_json totals_json(const DatasetTotals& t)
{
    return {{"scenes", t.scenes},
            {"failed", t.failed},
            {"instances_true", t.instances_true},
            {"instances_true_by_surface", t.instances_true_by_surface},
            {"instances_false", t.instances_false},
            {"instances_missed", t.instances_missed},
            {"false_on_negatives", t.false_on_negatives},
            {"truth_instances", t.truth},
            {"visible_instances", t.visible},
            {"visible_found", t.visible_found},
            {"recall_visible", t.recall_visible()},
            {"correspondences", t.correspondences},
            {"correct_correspondences", t.correct_correspondences},
            {"possible_correspondences", t.possible_correspondences},
            {"correspondence_precision", t.precision()},
            {"correspondence_sensitivity", t.sensitivity()},
            {"median_scene_ms", t.median_ms()},
            {"median_placement_ms", t.median_placement_ms()},
            {"structures", t.structures},
            {"points_used", t.points_used},
            {"fallbacks", t.fallbacks},
            {"peak_memory_bytes", t.peak_memory}};
}


}  // namespace

double DatasetTotals::precision() const
{
    return correspondences == 0 ? 0.0 : double(correct_correspondences) / double(correspondences);
}

double DatasetTotals::sensitivity() const
{
    return possible_correspondences == 0 ? 0.0 : sensitivity_sum / double(possible_correspondences);
}

double DatasetTotals::recall_visible() const
{
    return visible == 0 ? std::numeric_limits<double>::quiet_NaN() : double(visible_found) / double(visible);
}

double DatasetTotals::median_ms() const { return median_of(scene_ms); }

double DatasetTotals::median_placement_ms() const { return median_of(placement_ms); }

DatasetReport evaluate_dataset(const Dataset& dataset, const RecognitionParams& params, bool check_cache_params,
                               const std::string& params_source, const DatasetOptions& options,
                               const DatasetProgress& progress)
{
    check_recognition_params(params, params_source.empty() ? "params" : params_source);
    if (!(options.min_visible_fraction >= 0.0f && options.min_visible_fraction <= 1.0f))
        throw Error("evaluate", "the least visible fraction must lie in [0, 1], got " +
                                    format_number(options.min_visible_fraction));
    check_placement_params(options.placement, "placement");
    for (std::size_t i = 0; i < options.placements.size(); ++i)
        for (std::size_t j = 0; j < i; ++j)
            if (options.placements[i] == options.placements[j])
                throw Error("placement", std::string("'") + to_string(options.placements[i]) + "' given twice");
    check_dataset_files(dataset);
    DatasetReport report;
    report.dataset = dataset.name;
    report.params_source = params_source;
    report.params = params;
    report.options = options;
    report.threads = int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));

    // Models load on first need, so a set whose scenes use few of many models reads only those.
    std::map<std::string, std::optional<Model>> models;
    auto model_of = [&](const std::string& name) -> std::size_t {
        for (std::size_t i = 0; i < report.models.size(); ++i)
            if (report.models[i].name == name) return i;
        const auto it = std::find_if(dataset.models.begin(), dataset.models.end(),
                                     [&](const DatasetModel& m) { return m.name == name; });
        if (it == dataset.models.end()) throw Error(dataset.source.string(), "no model named '" + name + "'");
        ModelOutcome outcome;
        outcome.name = name;
        outcome.file = it->file.string();
        outcome.cached = is_model_cache(it->file);
        const auto start = Clock::now();
        try {
            models[name] = load_model(it->file, params.model, check_cache_params, params_source);
            prepare_model_verification(*models[name], params);
            outcome.keypoints = models[name]->features.size();
            outcome.params = models[name]->params;
        } catch (const std::exception& error) {
            models[name] = std::nullopt;
            outcome.error = error.what();
        }
        outcome.ms = elapsed_ms(start);
        report.models.push_back(outcome);
        return report.models.size() - 1;
    };

    std::size_t total = 0;
    for (const DatasetScene& scene : dataset.scenes)
        total += options.plain + (options.foveated && !scene.fovea.empty()) + options.placements.size();
    std::size_t done = 0;
    // track follows each group's scenes as the frames of one sequence (and a model's, when they
    // differ); a scene of no group is a sequence of its own.
    std::map<std::pair<std::string, std::string>, PlacementTrack> tracks;
    for (const DatasetScene& scene : dataset.scenes) {
        const ModelOutcome& model = report.models[model_of(scene.model)];
        const std::optional<Model>& loaded = models[scene.model];
        std::vector<SceneRun> runs;
        if (options.plain) runs.push_back({});
        if (options.foveated && !scene.fovea.empty()) runs.push_back({true, std::nullopt, nullptr});
        for (const PlacementStrategy strategy : options.placements)
            runs.push_back({false, strategy,
                            strategy == PlacementStrategy::track
                                ? &tracks[{scene.group.empty() ? "scene " + scene.name : "group " + scene.group, scene.model}]
                                : nullptr});
        for (const SceneRun& run : runs) {
            report.scenes.push_back(run_scene(scene, loaded ? &*loaded : nullptr, model.error, params, run, options));
            if (progress) progress(++done, total, scene.name);
        }
    }
    return report;
}

std::vector<DatasetTally> tally(const DatasetReport& report)
{
    std::vector<DatasetTally> rows;
    const float min_visible = report.options.min_visible_fraction;
    std::vector<std::string> strategies;
    for (const SceneOutcome& scene : report.scenes)
        if (std::find(strategies.begin(), strategies.end(), scene.strategy) == strategies.end())
            strategies.push_back(scene.strategy);
    for (const std::string& strategy : strategies) {
        DatasetTally all{strategy, "all", "", {}};
        std::map<std::string, DatasetTotals> groups;
        std::map<std::string, DatasetTotals> objects;
        for (const SceneOutcome& scene : report.scenes) {
            if (scene.strategy != strategy) continue;
            add(all.totals, scene, min_visible);
            if (!scene.group.empty()) add(groups[scene.group], scene, min_visible);
            // Per shape: each ground-truth instance on its own (scene-wide counts do not split by shape).
            for (const TruthOutcome& t : scene.truth) {
                DatasetTotals& o = objects[t.object.empty() ? scene.model : t.object];
                ++o.truth;
                o.instances_true += t.found;
                o.instances_missed += !t.found;
                if (!counts_as_visible(t, min_visible)) continue;
                ++o.visible;
                o.visible_found += t.found;
            }
        }
        if (all.totals.scenes == 0) continue;
        rows.push_back(all);
        for (auto& [key, totals] : groups) rows.push_back({strategy, "group", key, totals});
        for (auto& [key, totals] : objects) rows.push_back({strategy, "object", key, totals});
    }
    return rows;
}

std::string to_json(const DatasetReport& report)
{
    ordered_json models = ordered_json::array();
    for (const ModelOutcome& m : report.models)
        models.push_back({{"name", m.name},
                          {"file", m.file},
                          {"cached", m.cached},
                          {"keypoints", m.keypoints},
                          {"params", m.error.empty() ? ordered_json::parse(to_json(m.params)) : ordered_json(nullptr)},
                          {"ms", m.ms},
                          {"error", m.error.empty() ? ordered_json(nullptr) : ordered_json(m.error)}});
    ordered_json scenes = ordered_json::array();
    for (const SceneOutcome& s : report.scenes) {
        ordered_json truth = ordered_json::array();
        for (const TruthOutcome& t : s.truth) {
            ordered_json item = {{"object", t.object}, {"visible_fraction", shortest_double(t.visible_fraction)}, {"found", t.found}};
            if (!t.lost.empty()) item["lost"] = t.lost;
            if (t.correct_correspondences >= 0) item["correct_correspondences"] = t.correct_correspondences;
            truth.push_back(item);
        }
        const Evaluation& e = s.evaluation;
        ordered_json item = {{"scene", s.scene}, {"model", s.model},       {"strategy", s.strategy},
                             {"group", s.group}, {"negative", s.negative}, {"error", nullptr}};
        if (!s.error.empty()) {
            item["error"] = s.error;
        } else {
            item.update({{"instances", s.instances},
                         {"instances_true", e.instances_true},
                         {"instances_true_by_surface", e.instances_true_by_surface},
                         {"instances_false", e.instances_false},
                         {"instances_missed", e.instances_missed},
                         {"truth", truth},
                         {"scene_points", s.scene_points},
                         {"scene_keypoints", s.scene_keypoints},
                         {"correspondences", s.correspondences},
                         {"correct_correspondences", e.correct_correspondences},
                         {"possible_correspondences", e.possible_correspondences},
                         {"correspondence_precision", e.correspondence_precision},
                         {"correspondence_sensitivity", e.correspondence_sensitivity},
                         {"read_ms", s.read_ms},
                         {"scene_ms", s.scene_ms},
                         {"placement_ms", s.placement_ms},
                         {"structures", s.structures},
                         {"points_used", s.points_used},
                         {"fallback", s.fallback.empty() ? ordered_json(nullptr) : ordered_json(s.fallback)},
                         {"timings_ms",
                          {{"foveate", s.timings.foveate},
                           {"normals", s.timings.normals},
                           {"keypoints", s.timings.keypoints},
                           {"lrf", s.timings.lrf},
                           {"descriptors", s.timings.descriptors},
                           {"match", s.timings.match},
                           {"group", s.timings.group},
                           {"verify", s.timings.verify}}},
                         {"peak_memory_bytes", s.peak_memory},
                         {"peak_memory_reset", s.peak_memory_reset}});
        }
        scenes.push_back(item);
    }
    ordered_json tallies = ordered_json::array();
    for (const DatasetTally& t : tally(report)) {
        ordered_json row = {{"strategy", t.strategy}, {"kind", t.kind}, {"key", t.key}};
        row.update(totals_json(t.totals));
        tallies.push_back(row);
    }
    const EvaluationParams& tolerances = report.options.evaluation;
    const ordered_json out = {
        {"dataset", report.dataset},
        {"threads", report.threads},
        {"params_source", report.params_source},
        {"params", ordered_json::parse(to_json(report.params))},
        {"min_visible_fraction", shortest_double(report.options.min_visible_fraction)},
        {"placement", placement_json(report.options)},
        {"tolerances",
         {{"correspondence_m", shortest_double(tolerances.correspondence_tolerance)},
          {"instance_m", shortest_double(tolerances.instance_translation)},
          {"instance_deg", shortest_double(tolerances.instance_angle_deg)},
          {"surface_m", shortest_double(tolerances.surface_tolerance)},
          {"surface_agreement", shortest_double(tolerances.surface_agreement)}}},
        {"models", models},
        {"scenes", scenes},
        {"totals", tallies}};
    return detail::json_text(out);
}

std::string to_csv(const DatasetReport& report)
{
    std::ostringstream out;
    out << "scene,model,strategy,group,negative,error,instances,true,false,missed,truth,visible,visible_found,"
           "scene_points,scene_keypoints,correspondences,correct_correspondences,possible_correspondences,"
           "precision,sensitivity,read_ms,scene_ms,peak_memory_bytes,placement_ms,structures,points_used,fallback\n";
    for (const SceneOutcome& s : report.scenes) {
        std::size_t visible = 0, visible_found = 0;
        for (const TruthOutcome& t : s.truth) {
            if (!counts_as_visible(t, report.options.min_visible_fraction)) continue;
            ++visible;
            visible_found += t.found;
        }
        const Evaluation& e = s.evaluation;
        out << csv_field(s.scene) << ',' << csv_field(s.model) << ',' << s.strategy << ',' << csv_field(s.group) << ','
            << (s.negative ? "true" : "false") << ',' << csv_field(s.error) << ',';
        if (!s.error.empty()) {
            out << std::string(20, ',') << '\n';
            continue;
        }
        out << s.instances << ',' << e.instances_true << ',' << e.instances_false << ',' << e.instances_missed << ','
            << s.truth.size() << ',' << visible << ',' << visible_found << ',' << s.scene_points << ','
            << s.scene_keypoints << ',' << s.correspondences << ',' << e.correct_correspondences << ','
            << e.possible_correspondences << ',' << format_fixed(e.correspondence_precision, 4) << ','
            << format_fixed(e.correspondence_sensitivity, 4) << ',' << format_fixed(s.read_ms, 2) << ',' << format_fixed(s.scene_ms, 2)
            << ',' << s.peak_memory << ',' << format_fixed(s.placement_ms, 2) << ',' << s.structures << ','
            << s.points_used << ',' << csv_field(s.fallback) << '\n';
    }
    return out.str();
}

std::string to_table(const DatasetReport& report)
{
    std::ostringstream out;
    char line[512];
    std::snprintf(line, sizeof line, "%-28s %-8s %5s %5s %6s %9s %9s %8s %8s  %s\n", "scene", "run", "true", "false",
                  "missed", "precision", "sensitiv.", "ms", "peak MB", "note");
    out << line;
    for (const SceneOutcome& s : report.scenes) {
        if (!s.error.empty()) {
            std::snprintf(line, sizeof line, "%-28s %-8s %5s %5s %6s %9s %9s %8s %8s  ", s.scene.c_str(),
                          s.strategy.c_str(), "-", "-", "-", "-", "-", "-", "-");
            out << line << "error: " << s.error << '\n';
            continue;
        }
        const Evaluation& e = s.evaluation;
        std::string note = s.negative ? "negative" : "";
        if (!s.fallback.empty()) note += (note.empty() ? "" : "; ") + s.fallback;
        std::string lost;
        for (const TruthOutcome& t : s.truth)
            if (!t.lost.empty()) lost += (lost.empty() ? "" : ", ") + t.lost;
        if (!lost.empty()) note += (note.empty() ? "" : "; ") + ("lost at " + lost);
        std::snprintf(line, sizeof line, "%-28s %-8s %5zu %5zu %6zu %9.3f %9.3f %8.1f %8s  ", s.scene.c_str(),
                      s.strategy.c_str(), e.instances_true, e.instances_false, e.instances_missed,
                      e.correspondence_precision, e.correspondence_sensitivity, s.scene_ms,
                      mebibytes(s.peak_memory).c_str());
        out << line << note << '\n';
    }
    out << '\n';
    std::snprintf(line, sizeof line, "%-8s %-22s %6s %6s %5s %5s %6s %7s %9s %9s %10s %9s %10s %8s\n", "run", "totals",
                  "scenes", "failed", "true", "false", "missed", "recall*", "precision", "sensitiv.", "median ms",
                  "place ms", "points", "peak MB");
    out << line;
    for (const DatasetTally& t : tally(report)) {
        const DatasetTotals& x = t.totals;
        const std::string label = t.kind == "all" ? "all" : t.kind + " " + t.key;
        if (t.kind == "object") {
            std::snprintf(line, sizeof line, "%-8s %-22s %6s %6s %5zu %5s %6zu %7s\n", t.strategy.c_str(),
                          label.c_str(), "", "", x.instances_true, "", x.instances_missed,
                          recall_text(x.recall_visible()).c_str());
        } else {
            std::snprintf(line, sizeof line,
                          "%-8s %-22s %6zu %6zu %5zu %5zu %6zu %7s %9.3f %9.3f %10.1f %9.1f %10s %8s\n",
                          t.strategy.c_str(), label.c_str(), x.scenes, x.failed, x.instances_true, x.instances_false,
                          x.instances_missed, recall_text(x.recall_visible()).c_str(), x.precision(), x.sensitivity(),
                          x.median_ms(), x.median_placement_ms(), group_digits(x.points_used).c_str(),
                          mebibytes(x.peak_memory).c_str());
        }
        out << line;
    }
    out << "* recall of the instances with at least " << format_fixed(report.options.min_visible_fraction * 100.0, 0)
        << "% of their surface visible (all of them where the ground truth does not say); median ms includes "
           "placement; points: described, summed\n";
    return out.str();
}

}  // namespace mfpc
