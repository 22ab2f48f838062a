#include "mfpc/batch/scaling.hpp"

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "mfpc/core/detail/text_format.hpp"
#include "mfpc/core/error.hpp"

namespace mfpc {
namespace {

// What every format says of one point, against the first.
struct Scaling {
    double throughput = 0;  // scenes per second
    double speedup = 0;
    double efficiency = 0;
    double read = 0, place = 0, describe = 0, models = 0;  // per-stage efficiency
};

double per_scene(double stage_ms, const BatchSummary& s)
{
    const std::size_t run = s.recognised + s.failed;
    return run > 0 ? stage_ms / double(run) : 0.0;
}

std::vector<Scaling> scaling_of(const std::vector<ScalingPoint>& points)
{
    if (points.empty()) throw Error("scaling", "no thread count was run");
    const ScalingPoint& first = points.front();
    auto throughput = [](const BatchSummary& s) {
        return s.seconds > 0 ? double(s.recognised + s.failed) / s.seconds : 0.0;
    };
    // A stage's efficiency: its time per scene at the first count over its time per scene here,
    // each in worker time. 1: the stage does its work as fast on every thread.
    auto stage = [&](const ScalingPoint& p, double StageTimes::*field) {
        const double here = per_scene(p.summary.stages.*field, p.summary);
        return here > 0 ? per_scene(first.summary.stages.*field, first.summary) / here : 0.0;
    };
    std::vector<Scaling> out;
    for (const ScalingPoint& p : points) {
        Scaling s;
        s.throughput = throughput(p.summary);
        s.speedup = throughput(first.summary) > 0 ? s.throughput / throughput(first.summary) : 0.0;
        s.efficiency = s.speedup * double(first.threads) / double(p.threads);
        s.read = stage(p, &StageTimes::read);
        s.place = stage(p, &StageTimes::place);
        s.describe = stage(p, &StageTimes::describe);
        s.models = stage(p, &StageTimes::models);
        out.push_back(s);
    }
    return out;
}

}  // namespace

std::vector<int> default_thread_counts(int cores)
{
    cores = std::max(cores, 1);
    std::vector<int> counts;
    for (int t = 1; t < cores; t *= 2) counts.push_back(t);
    counts.push_back(cores);
    return counts;
}

std::vector<ScalingPoint> run_scaling(const BatchJob& job, const std::vector<int>& threads,
                                      const std::filesystem::path& directory, const std::function<void(int)>& progress)
{
    if (threads.empty()) throw Error("scaling", "no thread count to run");
    for (int t : threads)
        if (t < 1 || t > 4096) throw Error("scaling", "thread count " + std::to_string(t) + " is not 1..4096");
    std::vector<ScalingPoint> points;
    for (int t : threads) {
        if (progress) progress(t);
        const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(t));
        const std::filesystem::path records = directory / ("threads_" + std::to_string(t) + ".jsonl");
        std::error_code error;
        std::filesystem::remove(records, error);
        BatchOutput output(records, false);
        points.push_back({t, run_batch(job, output)});
    }
    return points;
}

std::string to_csv(const std::vector<ScalingPoint>& points)
{
    const std::vector<Scaling> scaling = scaling_of(points);
    using detail::format_fixed;
    std::string csv = detail::csv_row({"threads", "scenes", "seconds", "scenes_per_second", "speedup", "efficiency",
                                       "read_efficiency", "place_efficiency", "describe_efficiency", "models_efficiency",
                                       "peak_memory_bytes"});
    for (std::size_t i = 0; i < points.size(); ++i) {
        const BatchSummary& s = points[i].summary;
        const Scaling& k = scaling[i];
        csv += detail::csv_row({std::to_string(points[i].threads), std::to_string(s.recognised + s.failed),
                                format_fixed(s.seconds, 3), format_fixed(k.throughput, 4), format_fixed(k.speedup, 3),
                                format_fixed(k.efficiency, 3), format_fixed(k.read, 3), format_fixed(k.place, 3),
                                format_fixed(k.describe, 3),
                                format_fixed(k.models, 3), std::to_string(s.peak_memory_bytes)});
    }
    return csv;
}

std::string to_json(const std::vector<ScalingPoint>& points)
{
    const std::vector<Scaling> scaling = scaling_of(points);
    nlohmann::ordered_json out = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < points.size(); ++i) {
        const Scaling& k = scaling[i];
        out.push_back({{"threads", points[i].threads},
                       {"scenes_per_second", k.throughput},
                       {"speedup", k.speedup},
                       {"efficiency", k.efficiency},
                       {"stage_efficiency", {{"read", k.read}, {"place", k.place}, {"describe", k.describe}, {"models", k.models}}},
                       {"summary", nlohmann::ordered_json::parse(to_json(points[i].summary))}});
    }
    return nlohmann::ordered_json({{"points", out}}).dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) +
           '\n';
}

}  // namespace mfpc
