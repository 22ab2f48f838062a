#include "mfpc/recognition/recognition_report.hpp"

#include <cstdio>

#include <nlohmann/json.hpp>

#include "mfpc/core/detail/text_format.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/json_check.hpp"
#include "mfpc/core/pose.hpp"
#include "mfpc/core/detail/text_file.hpp"
#include "json_fields.hpp"

namespace mfpc {
namespace {

using nlohmann::ordered_json;
using detail::format_fixed;
using detail::group_digits;

ordered_json row_major(const Pose& pose)
{
    ordered_json out = ordered_json::array();
    for (double v : pose_to_row_major(pose)) out.push_back(v);
    return out;
}

// The parameters as they were used: the scene side from the run, the model side from the model.
ordered_json params_json(const RecognitionReport& report)
{
    RecognitionParams used = report.params;
    used.model = report.model_params;
    return ordered_json::parse(to_json(used));
}

}  // namespace

std::string to_json(const RecognitionReport& report)
{
    const RecognitionResult& result = report.result;
    const std::optional<Evaluation>& evaluation = report.evaluation;
    ordered_json instances = ordered_json::array();
    for (std::size_t i = 0; i < result.instances.size(); ++i) {
        const Instance& instance = result.instances[i];
        const Point position = instance.transform * report.model_centroid;
        ordered_json item = {{"transform", row_major(instance.transform)},
                             {"position", {position.x(), position.y(), position.z()}},
                             {"votes", instance.votes},
                             {"correspondences", instance.correspondences.size()},
                             {"fitness", instance.fitness},
                             {"coverage", instance.coverage},
                             {"free_space_violation", instance.free_space_violation},
                             {"thickness_ratio", instance.thickness_ratio},
                             {"continuation", instance.continuation},
                             {"rmse", instance.rmse}};
        if (evaluation) {
            item["ground_truth_instance"] = evaluation->instance_match[i];
            item["position_error_m"] = evaluation->position_error[i];
            item["rotation_error_deg"] = evaluation->rotation_error_deg[i];
        }
        instances.push_back(item);
    }
    const RecognitionCounts& c = result.counts;
    const RecognitionTimings& t = result.timings;
    ordered_json json = {
        {"model", report.model_file},
        {"scene", report.scene_file},
        {"mode", to_string(report.mode)},
        {"instances", instances},
        {"counts",
         {{"scene_points", c.scene_points},
          {"scene_points_used", c.scene_points_used},
          {"scene_keypoints", c.scene_keypoints},
          {"scene_keypoints_invalid", c.scene_keypoints_invalid},
          {"model_keypoints", c.model_keypoints},
          {"model_keypoints_invalid", c.model_keypoints_invalid},
          {"correspondences", c.correspondences},
          {"instances_before_verification", c.instances_before_verification}}},
        {"timings_ms",
         {{"read_scene", report.read_scene_ms},
          {"foveate", t.foveate},
          {"normals", t.normals},
          {"keypoints", t.keypoints},
          {"lrf", t.lrf},
          {"descriptors", t.descriptors},
          {"match", t.match},
          {"group", t.group},
          {"verify", t.verify},
          {"total", t.total}}},
        {"model_timings_ms",
         {{"cached", report.model_cached},
          {"total", report.model_ms},
          {"normals", report.model_timings.normals_ms},
          {"lrf", report.model_timings.lrf_ms},
          {"descriptors", report.model_timings.descriptors_ms}}},
        {"threads", report.threads},
        {"params", params_json(report)},
        {"warnings", report.warnings},
        {"placement", report.placement ? ordered_json::parse(to_json(*report.placement)) : ordered_json(nullptr)},
    };
    if (evaluation) {
        json["evaluation"] = {{"ground_truth", report.ground_truth_file},
                              {"instances_true", evaluation->instances_true},
                              {"instances_true_by_surface", evaluation->instances_true_by_surface},
                              {"instances_false", evaluation->instances_false},
                              {"instances_missed", evaluation->instances_missed},
                              {"correct_correspondences", evaluation->correct_correspondences},
                              {"possible_correspondences", evaluation->possible_correspondences},
                              {"correspondence_precision", evaluation->correspondence_precision},
                              {"correspondence_sensitivity", evaluation->correspondence_sensitivity},
                              {"tolerances",
                               {{"correspondence_m", report.evaluation_params.correspondence_tolerance},
                                {"instance_m", report.evaluation_params.instance_translation},
                                {"instance_deg", report.evaluation_params.instance_angle_deg},
                                {"surface_m", report.evaluation_params.surface_tolerance},
                                {"surface_agreement", report.evaluation_params.surface_agreement}}}};
    }
    return detail::json_text(json);
}

std::string to_json(std::span<const RecognitionReport> reports, const RecognitionTimings& scene_timings)
{
    if (reports.empty()) throw Error("recognition report", "no model's report to write");
    ordered_json models = ordered_json::array();
    for (const RecognitionReport& report : reports) models.push_back(ordered_json::parse(to_json(report)));
    const RecognitionTimings& t = scene_timings;
    const ordered_json json = {{"scene", reports.front().scene_file},
                               {"mode", to_string(reports.front().mode)},
                               {"scene_timings_ms",
                                {{"read_scene", reports.front().read_scene_ms},
                                 {"foveate", t.foveate},
                                 {"normals", t.normals},
                                 {"keypoints", t.keypoints},
                                 {"lrf", t.lrf},
                                 {"descriptors", t.descriptors},
                                 {"evidence", t.verify},
                                 {"total", t.total}}},
                               {"models", models}};
    return detail::json_text(json);
}

std::string to_table(const RecognitionReport& report)
{
    const RecognitionResult& result = report.result;
    const std::optional<Evaluation>& evaluation = report.evaluation;
    const RecognitionCounts& c = result.counts;
    const RecognitionTimings& t = result.timings;
    std::vector<std::pair<std::string, std::string>> rows = {
        {"model", report.model_file + (report.model_cached ? " (cached)" : "")},
        {"scene", report.scene_file},
        {"mode", to_string(report.mode)},
    };
    if (report.placement) rows.push_back({"placement", summary(*report.placement)});
    rows.insert(rows.end(), {
        {"scene points", group_digits(c.scene_points) + " finite, " + group_digits(c.scene_points_used) + " used"},
        {"keypoints", group_digits(c.scene_keypoints) + " scene (" + group_digits(c.scene_keypoints_invalid) +
                          " invalid), " + group_digits(c.model_keypoints) + " model"},
        {"correspondences", group_digits(c.correspondences)},
        {"instances", group_digits(result.instances.size()) + " (" + group_digits(c.instances_before_verification) +
                          " before verification)"}});
    std::string out = detail::key_value_rows(rows);
    if (!result.instances.empty()) {
        out += "\n  #  position (m)                 votes  corrs  fitness  free-space";
        if (evaluation) out += "  ground truth";
        out += '\n';
        for (std::size_t i = 0; i < result.instances.size(); ++i) {
            const Instance& instance = result.instances[i];
            const Point p = instance.transform * report.model_centroid;
            char line[160];
            std::snprintf(line, sizeof line, "%3zu  (%7.3f, %7.3f, %7.3f)  %6.1f  %5zu  %7.3f  %10.3f", i, p.x(), p.y(),
                          p.z(), instance.votes, instance.correspondences.size(), instance.fitness,
                          instance.free_space_violation);
            out += line;
            if (evaluation) {
                const int match = evaluation->instance_match[i];
                out += "  " + (match >= 0 ? "instance " + std::to_string(match) : std::string("false")) + " (" +
                       format_fixed(evaluation->position_error[i] * 1000.0, 1) + " mm, " +
                       format_fixed(evaluation->rotation_error_deg[i], 2) + " deg)";
            }
            out += '\n';
        }
    }
    if (evaluation) {
        out += "\nevaluation  true " + std::to_string(evaluation->instances_true) + "  false " +
               std::to_string(evaluation->instances_false) + "  missed " + std::to_string(evaluation->instances_missed) +
               "  correct correspondences " + std::to_string(evaluation->correct_correspondences) + "  precision " +
               format_fixed(evaluation->correspondence_precision, 3) + "  sensitivity " +
               format_fixed(evaluation->correspondence_sensitivity, 3) + '\n';
    }
    out += "\ntimings (ms)  foveate " + format_fixed(t.foveate, 1) + "  normals " + format_fixed(t.normals, 1) +
           "  keypoints " + format_fixed(t.keypoints, 1) + "  lrf " + format_fixed(t.lrf, 1) + "  descriptors " +
           format_fixed(t.descriptors, 1) + "  match " + format_fixed(t.match, 1) + "  group " +
           format_fixed(t.group, 1) + "  verify " + format_fixed(t.verify, 1) + "  total " + format_fixed(t.total, 1) +
           "\nmodel (ms)    " + (report.model_cached ? "read from cache " : "described ") +
           format_fixed(report.model_ms, 1) + '\n';
    return out;
}

InstancePoses read_instance_poses(const std::filesystem::path& path)
{
    const std::string where = path.string();
    const std::string text = read_text_file(path);
    // Duplicate keys, deep nesting and syntax errors, named the way every JSON reader names them;
    // the text is then known to parse.
    check_json_text(text, where);
    nlohmann::json json = nlohmann::json::parse(text);
    if (!json.is_object()) throw Error(where, "not a recognize result: the top level is not an object");
    if (!json.contains("model") || !json["model"].is_string() || json["model"].get<std::string>().empty())
        throw Error(where + ": model", "missing or not a file name");
    if (!json.contains("instances") || !json["instances"].is_array())
        throw Error(where + ": instances", "missing or not an array");
    // More than max_instance_poses means the wrong file, not a picture anyone can read.
    if (json["instances"].size() > max_instance_poses)
        throw Error(where + ": instances", "holds " + std::to_string(json["instances"].size()) +
                                               " instances; at most " + std::to_string(max_instance_poses) +
                                               " can be drawn");

    InstancePoses instances;
    const std::filesystem::path model = json["model"].get<std::string>();
    // As the user ran `recognize`: relative to the current directory; a result moved with its
    // model (or a ground truth beside its model) also works.
    std::error_code status_error;
    if (model.is_absolute() || std::filesystem::exists(model, status_error)) {
        instances.model = model;
    } else if (std::filesystem::exists(path.parent_path() / model, status_error)) {
        instances.model = path.parent_path() / model;
    } else {
        throw Error(where + ": model", "'" + model.string() + "' is neither in the current directory nor beside " +
                                           path.filename().string());
    }
    const auto& items = json["instances"];
    for (std::size_t i = 0; i < items.size(); ++i) {
        const std::string key = where + ": instances[" + std::to_string(i) + "].transform";
        if (!items[i].is_object() || !items[i].contains("transform") || !items[i]["transform"].is_array())
            throw Error(key, "missing or not an array");
        const auto& values = items[i]["transform"];
        std::vector<double> numbers;
        for (const auto& value : values) {
            if (!value.is_number()) throw Error(key, "holds something that is not a number");
            numbers.push_back(value.get<double>());
        }
        if (numbers.size() != 16) throw Error(key, "needs 16 numbers, has " + std::to_string(numbers.size()));
        instances.transforms.push_back(pose_from_row_major(numbers, key));
    }
    return instances;
}

}  // namespace mfpc

