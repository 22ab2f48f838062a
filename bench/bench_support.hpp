#pragma once

// Shared by the benchmark programs: ratio reporting. Each program registers pairs of benchmarks
// (a baseline and ours) and, after the runs, prints baseline / ours from the medians of the
// repetitions measured in the same process.

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <tbb/info.h>

namespace mfpc::bench {

// The thread counts a scaling table runs: 1, 2, 4, ... and the cores present (on 2 cores: 1, 2).
inline const std::vector<int>& thread_counts()
{
    static const std::vector<int> counts = [] {
        std::vector<int> c;
        const int cores = tbb::info::default_concurrency();
        for (int t = 1; t < cores; t *= 2) c.push_back(t);
        c.push_back(cores);
        return c;
    }();
    return counts;
}

// Remembers each benchmark's median real time (ms), or its only run when not repeated.
class RecordingReporter : public benchmark::ConsoleReporter {
public:
    void ReportRuns(const std::vector<Run>& runs) override
    {
        for (const Run& run : runs) {
            if (run.error_occurred) continue;
            const bool median = run.run_type == Run::RT_Aggregate && run.aggregate_name == "median";
            const bool single = run.run_type == Run::RT_Iteration && run.repetitions <= 1;
            if (median || single) {
                std::string name = run.run_name.function_name;
                if (!run.run_name.args.empty()) name += "/" + run.run_name.args;
                times_ms_[name] = run.GetAdjustedRealTime() * to_ms(run.time_unit);
                for (const auto& [key, counter] : run.counters) counters_[name][key] = counter.value;
            }
        }
        ConsoleReporter::ReportRuns(runs);
    }

    // Median time of a benchmark by its name, or a negative number when it did not run.
    double time_ms(const std::string& name) const
    {
        const auto it = times_ms_.find(name);
        return it == times_ms_.end() ? -1.0 : it->second;
    }

    // A user counter of a benchmark (the median over the repetitions, as Google Benchmark
    // aggregates counters), or a negative number when it did not run or has no such counter.
    double counter(const std::string& name, const std::string& key) const
    {
        const auto it = counters_.find(name);
        if (it == counters_.end()) return -1.0;
        const auto value = it->second.find(key);
        return value == it->second.end() ? -1.0 : value->second;
    }

    void print_ratio(const std::string& label, const std::string& baseline, const std::string& ours) const
    {
        const double b = time_ms(baseline);
        const double o = time_ms(ours);
        if (b < 0 || o <= 0) {
            std::printf("%-58s (not run)\n", label.c_str());
            return;
        }
        std::printf("%-58s %10.3f ms / %10.3f ms = %8.2fx\n", label.c_str(), b, o, b / o);
    }

private:
    static double to_ms(benchmark::TimeUnit unit)
    {
        switch (unit) {
        case benchmark::kNanosecond: return 1e-6;
        case benchmark::kMicrosecond: return 1e-3;
        case benchmark::kMillisecond: return 1.0;
        case benchmark::kSecond: return 1e3;
        }
        return 1.0;
    }
    std::map<std::string, double> times_ms_;
    std::map<std::string, std::map<std::string, double>> counters_;
};

}  // namespace mfpc::bench
