#pragma once

#include <string>
#include <vector>

#include "mfpc/recognition/experiment.hpp"

namespace mfpc {

/// What `mfpc experiment` reports: the paper's Table 7 (time per strategy, its 95% interval and
/// reduction against the reference strategy) and the metrics of Figures 11 and 12.
struct ExperimentReport {
    std::string config_file;                ///< the experiment config, as given
    ExperimentConfig config;                ///< as read (runs possibly overridden)
    std::vector<StrategyOutcome> outcomes;  ///< one per strategy of `config`, in its order
    double model_ms = 0;                    ///< preparing the model (apart from the scene work)
    bool model_cached = false;              ///< the model came from a cache (.mfpcm)
    int threads = 1;                        ///< worker threads of the run
};

/// report.json: configuration, parameters and, per strategy, counts, evaluation, a summary
/// (mean, variance, 95% interval, median, ...) of each stage's time and every run's total.
/// @throws mfpc::Error when outcomes and strategies differ in number
std::string to_json(const ExperimentReport& report);

/// report.csv: one row per strategy (header first).
/// @throws mfpc::Error when outcomes and strategies differ in number
std::string to_csv(const ExperimentReport& report);

/// report.md: Table 7's layout (time, interval, reduction), the mean time per stage and the
/// metrics table.
/// @throws mfpc::Error when outcomes and strategies differ in number
std::string to_markdown(const ExperimentReport& report);

/// The charts' data: a header comment, then per strategy its quoted name, points, keypoints,
/// correspondences, correct ones, precision, sensitivity, true and false instances, and the mean
/// total time with its interval (the mean where one run leaves no interval).
/// @throws mfpc::Error when outcomes and strategies differ in number
std::string to_chart_data(const ExperimentReport& report);

}  // namespace mfpc
