#include "mfpc/recognition/experiment_report.hpp"

#include <cmath>
#include <sstream>

#include <nlohmann/json.hpp>

#include "mfpc/core/detail/text_format.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/recognition/statistics.hpp"
#include "json_fields.hpp"

namespace mfpc {
namespace {

using nlohmann::ordered_json;
using detail::csv_row;
using detail::group_digits;

std::string number(double value, int decimals) { return detail::format_fixed_or_na(value, decimals); }

// The stages of Figure 12's time chart and of the report, in pipeline order.
struct Stage {
    const char* name;
    double RecognitionTimings::*field;
};
constexpr Stage stages[] = {{"place", &RecognitionTimings::place},         {"foveate", &RecognitionTimings::foveate},
                            {"normals", &RecognitionTimings::normals},
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

ordered_json summary_json(const Summary& s)
{
    auto value = [](double v) { return std::isfinite(v) ? ordered_json(v) : ordered_json(); };
    return {{"runs", s.count},           {"mean", value(s.mean)},       {"variance", value(s.variance)},
            {"std", value(s.standard_deviation)}, {"t", value(s.t_quantile)}, {"ci95_low", value(s.low)},
            {"ci95_high", value(s.high)}, {"median", value(s.median)},  {"min", value(s.min)},
            {"max", value(s.max)}};
}

std::string mode_name(const ExperimentStrategy& s) { return s.serial ? "serial" : to_string(s.mode); }

// The structures a strategy foveated with: its first run's placement, else its config's.
std::size_t structures_of(const ExperimentStrategy& s, const StrategyOutcome& o)
{
    if (s.mode == FoveationMode::none) return 0;
    return o.placement ? o.placement->config.structures.size() : s.fovea.structures.size();
}

// What every part of the report shares: each strategy's total-time summary and the reference's mean.
struct Totals {
    std::vector<Summary> total;
    bool has_reference = false;
    double reference_mean = 0;
    std::string reference_name;

    explicit Totals(const ExperimentReport& report)
    {
        if (report.outcomes.size() != report.config.strategies.size())
            throw Error("experiment report", std::to_string(report.outcomes.size()) + " outcomes for " +
                                                 std::to_string(report.config.strategies.size()) + " strategies");
        for (const StrategyOutcome& o : report.outcomes) total.push_back(summarize_stage(o, &RecognitionTimings::total));
        has_reference = report.config.reference >= 0;
        if (has_reference) {
            reference_mean = total[std::size_t(report.config.reference)].mean;
            reference_name = report.config.strategies[std::size_t(report.config.reference)].name;
        }
    }
    double reduction(std::size_t i) const { return reduction_percent(reference_mean, total[i].mean); }
};

}  // namespace

std::string to_json(const ExperimentReport& report)
{
    const Totals totals(report);
    const ExperimentConfig& config = report.config;
    ordered_json strategies = ordered_json::array();
    for (std::size_t i = 0; i < report.outcomes.size(); ++i) {
        const StrategyOutcome& o = report.outcomes[i];
        const ExperimentStrategy& s = config.strategies[i];
        ordered_json times;
        for (const Stage& stage : stages) times[stage.name] = summary_json(summarize_stage(o, stage.field));
        ordered_json runs = ordered_json::array();
        for (const RecognitionTimings& t : o.timings) runs.push_back(t.total);
        const RecognitionCounts& c = o.counts;
        const Evaluation& e = o.evaluation;
        strategies.push_back(
            {{"name", o.name},
             {"mode", mode_name(s)},
             {"fovea", s.placement ? ordered_json("auto") : ordered_json(s.fovea_file.string())},
             {"placement", o.placement ? ordered_json::parse(to_json(*o.placement)) : ordered_json(nullptr)},
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
              totals.has_reference ? ordered_json(totals.reduction(i)) : ordered_json()}});
    }
    const ordered_json json = {
        {"config", report.config_file},
        {"model", config.model.string()},
        {"scene", config.scene.string()},
        {"ground_truth", config.ground_truth.string()},
        {"runs", config.runs},
        {"threads", report.threads},
        {"confidence", 0.95},
        {"interval", "mean ± t(0.975, runs - 1) s / sqrt(runs), Student's t (the paper's 1.96 is the normal quantile)"},
        {"reference", totals.has_reference ? ordered_json(totals.reference_name) : ordered_json()},
        {"model_preparation_ms", report.model_ms},
        {"model_cached", report.model_cached},
        {"params", ordered_json::parse(to_json(config.params))},
        {"strategies", strategies}};
    return detail::json_text(json);
}

std::string to_csv(const ExperimentReport& report)
{
    const Totals totals(report);
    std::string out = csv_row({"strategy", "mode", "structures", "points_before_downsampling", "redundant_points",
                               "scene_points_used", "keypoints", "correspondences", "correct_correspondences",
                               "precision", "sensitivity", "instances_true", "instances_false", "instances_missed",
                               "runs", "time_mean_ms", "time_variance_ms2", "ci95_low_ms", "ci95_high_ms",
                               "reduction_vs_reference_percent"});
    for (std::size_t i = 0; i < report.outcomes.size(); ++i) {
        const StrategyOutcome& o = report.outcomes[i];
        const Summary& t = totals.total[i];
        out += csv_row({o.name, mode_name(report.config.strategies[i]),
                        std::to_string(structures_of(report.config.strategies[i], o)),
                        std::to_string(o.counts.scene_points_foveated),
                        std::to_string(o.counts.redundant_points), std::to_string(o.counts.scene_points_used),
                        std::to_string(o.counts.scene_keypoints), std::to_string(o.counts.correspondences),
                        std::to_string(o.evaluation.correct_correspondences),
                        number(o.evaluation.correspondence_precision, 4),
                        number(o.evaluation.correspondence_sensitivity, 4), std::to_string(o.evaluation.instances_true),
                        std::to_string(o.evaluation.instances_false), std::to_string(o.evaluation.instances_missed),
                        std::to_string(t.count), number(t.mean, 3), number(t.variance, 3), number(t.low, 3),
                        number(t.high, 3), totals.has_reference ? number(totals.reduction(i), 2) : ""});
    }
    return out;
}

std::string to_markdown(const ExperimentReport& report)
{
    const Totals totals(report);
    const ExperimentConfig& config = report.config;
    const std::vector<StrategyOutcome>& outcomes = report.outcomes;
    std::string md = "# Experiment: " + config.scene.filename().string() + "\n\n" + std::to_string(config.runs) +
                     " runs per strategy; times are the scene work in ms (model preparation apart: " +
                     detail::format_fixed(report.model_ms, 1) + " ms" + (report.model_cached ? ", from cache" : "") +
                     "). Intervals: 95%, Student's t with runs - 1 degrees of freedom.\n\n";
    md += "| strategy | mean time (ms) | variance | 95% interval | reduction vs " +
          (totals.has_reference ? totals.reference_name : std::string("-")) + " |\n";
    md += "| --- | ---: | ---: | --- | ---: |\n";
    for (std::size_t i = 0; i < outcomes.size(); ++i) {
        const Summary& t = totals.total[i];
        md += "| " + outcomes[i].name + " | " + number(t.mean, 1) + " | " + number(t.variance, 1) + " | [" +
              number(t.low, 1) + ", " + number(t.high, 1) + "] | " +
              (totals.has_reference ? number(totals.reduction(i), 1) + "%" : "-") + " |\n";
    }
    md += "\nMean time per stage (ms):\n\n| strategy |";
    for (const Stage& stage : stages) md += std::string(" ") + stage.name + " |";
    md += "\n| --- |";
    for (std::size_t k = 0; k < std::size(stages); ++k) md += " ---: |";
    md += "\n";
    for (const StrategyOutcome& o : outcomes) {
        md += "| " + o.name + " |";
        for (const Stage& stage : stages) md += " " + number(summarize_stage(o, stage.field).mean, 1) + " |";
        md += "\n";
    }
    md += "\n| strategy | structures | points (before downsampling) | points used | keypoints | correspondences | "
          "correct | precision | sensitivity | true | false | missed |\n| --- | ---: | ---: | ---: | ---: | ---: | ---: | "
          "---: | ---: | ---: | ---: | ---: |\n";
    for (std::size_t i = 0; i < outcomes.size(); ++i) {
        const StrategyOutcome& o = outcomes[i];
        md += "| " + o.name + " | " + std::to_string(structures_of(config.strategies[i], o)) + " | " +
              group_digits(o.counts.scene_points_foveated) + " | " +
              group_digits(o.counts.scene_points_used) + " | " + group_digits(o.counts.scene_keypoints) + " | " +
              group_digits(o.counts.correspondences) + " | " + group_digits(o.evaluation.correct_correspondences) +
              " | " + number(o.evaluation.correspondence_precision, 3) + " | " +
              number(o.evaluation.correspondence_sensitivity, 3) + " | " + std::to_string(o.evaluation.instances_true) +
              " | " + std::to_string(o.evaluation.instances_false) + " | " +
              std::to_string(o.evaluation.instances_missed) + " |\n";
    }
    return md;
}

std::string to_chart_data(const ExperimentReport& report)
{
    const Totals totals(report);
    std::ostringstream out;
    out << "# strategy points keypoints correspondences correct precision sensitivity true false time low high\n";
    for (std::size_t i = 0; i < report.outcomes.size(); ++i) {
        // The config reader refuses '"' and control characters in names, so quoting suffices.
        const StrategyOutcome& o = report.outcomes[i];
        const Summary& t = totals.total[i];
        out << '"' << o.name << "\" " << o.counts.scene_points_used << ' ' << o.counts.scene_keypoints << ' '
            << o.counts.correspondences << ' ' << o.evaluation.correct_correspondences << ' '
            << o.evaluation.correspondence_precision << ' ' << o.evaluation.correspondence_sensitivity << ' '
            << o.evaluation.instances_true << ' ' << o.evaluation.instances_false << ' ' << t.mean << ' '
            << (std::isfinite(t.low) ? t.low : t.mean) << ' ' << (std::isfinite(t.high) ? t.high : t.mean) << '\n';
    }
    return out.str();
}

}  // namespace mfpc
