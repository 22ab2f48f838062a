#pragma once

/// @file
/// @brief The report of `mfpc experiment`: JSON, CSV, Markdown and the charts' data.

#include <string>
#include <vector>

#include "mfpc/recognition/experiment.hpp"

namespace mfpc {

/// @brief What `mfpc experiment` reports: the paper's Table 7 (time per strategy, its 95% interval
/// and reduction against the reference strategy) and the metrics of Figures 11 and 12.
struct ExperimentReport {
    std::string config_file;                ///< The experiment config, as given.
    ExperimentConfig config;                ///< As read (runs possibly overridden).
    std::vector<StrategyOutcome> outcomes;  ///< One per strategy of `config`, in its order.
    double model_ms = 0;                    ///< Preparing the model (apart from the scene work).
    bool model_cached = false;              ///< The model came from a cache (.mfpcm).
    int threads = 1;                        ///< Worker threads of the run.
};

/// @brief report.json: configuration, parameters and, per strategy, counts, evaluation, a summary
/// (mean, variance, 95% interval, median, ...) of each stage's time and every run's total.
/// @param report The experiment.
/// @return Indented JSON text with a final newline.
/// @throws mfpc::Error when outcomes and strategies differ in number.
std::string to_json(const ExperimentReport& report);

/// @brief report.csv: one row per strategy (header first).
/// @param report The experiment.
/// @return CSV text.
/// @throws mfpc::Error when outcomes and strategies differ in number.
std::string to_csv(const ExperimentReport& report);

/// @brief report.md: Table 7's layout (time, interval, reduction), the mean time per stage and the
/// metrics table.
/// @param report The experiment.
/// @return Markdown text.
/// @throws mfpc::Error when outcomes and strategies differ in number.
std::string to_markdown(const ExperimentReport& report);

/// @brief The charts' data: a header comment, then per strategy its quoted name, points, keypoints,
/// correspondences, correct ones, precision, sensitivity, true and false instances, and the mean
/// total time with its interval (the mean where one run leaves no interval).
/// @param report The experiment.
/// @return The data file's text, one line per strategy after the header.
/// @throws mfpc::Error when outcomes and strategies differ in number.
std::string to_chart_data(const ExperimentReport& report);

}  // namespace mfpc
