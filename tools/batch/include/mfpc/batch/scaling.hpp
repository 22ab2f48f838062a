#pragma once

/// @file
/// The scaling study: one batch at several thread counts, for deciding how to deploy.

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mfpc/batch/batch.hpp"

namespace mfpc {

/// One thread count of a scaling study and what its batch did.
struct ScalingPoint {
    int threads = 1;       ///< worker threads of the batch
    BatchSummary summary;  ///< its summary (stage times summed over scenes)
};

/// The thread counts a study runs by default: 1, 2, 4, ... doubling up to `cores`, and `cores`
/// itself when it is not a power of two.
/// @param cores the cores present (at least 1)
/// @return the counts, ascending
std::vector<int> default_thread_counts(int cores);

/// Runs the job once per thread count (in that order, each under a TBB thread limit), its records
/// into `directory`/threads_N.jsonl.
/// @param job the batch
/// @param threads the thread counts (each 1..4096)
/// @param directory an existing folder for the records
/// @param progress told before each thread count's batch (its count)
/// @return one point per thread count
/// @throws mfpc::Error for an empty or out-of-range thread count, or a record that cannot be written
std::vector<ScalingPoint> run_scaling(const BatchJob& job, const std::vector<int>& threads,
                                      const std::filesystem::path& directory,
                                      const std::function<void(int)>& progress = {});

/// The study as CSV, one row per thread count: throughput (scenes per second), speed-up and
/// efficiency end to end against the first count, and per stage (read, place, describe, models) the
/// efficiency: the stage's summed time at the first count over its summed time here, scaled by
/// the ratio of the counts (1 when the stage's work per scene does not grow with the threads; 0 for
/// a stage that took no time, as placement in a batch that does not place).
/// @param points the study (the first point is the reference)
/// @return CSV text with a header
/// @throws mfpc::Error for no points
std::string to_csv(const std::vector<ScalingPoint>& points);

/// The study as JSON text (the same numbers as to_csv, and each point's summary).
/// @param points the study
/// @return indented JSON text
/// @throws mfpc::Error for no points
std::string to_json(const std::vector<ScalingPoint>& points);

}  // namespace mfpc
