// Rays per second of the virtual scanner (Embree, TBB over rows) at 640x480 and 4096x4096, and
// its thread scaling: the same scan with 1, 2, 4, ... threads up to the machine's cores, each
// compared with 1 thread in this run. A scan includes the sensor model (noise, quantization,
// incidence and range cut) and the compaction into an organized cloud; the Embree scene is built
// once, apart, as a user scanning one scene many times would.
#include <cstdio>
#include <thread>

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "bench_support.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"
#include "mfpc/simulation/virtual_scanner.hpp"

namespace {

using namespace mfpc;

const SyntheticScene& tabletop()
{
    static const SyntheticScene scene = [] {
        ComposeParams params;
        params.objects = 3;
        params.distractors = 3;
        return compose_scene(builtin_scene_shapes(), params);
    }();
    return scene;
}

const VirtualScanner& scanner()
{
    static const VirtualScanner instance(tabletop());
    return instance;
}

void scan(benchmark::State& state)
{
    SensorParams sensor;
    sensor.width = std::uint32_t(state.range(0));
    sensor.height = std::uint32_t(state.range(1));
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(2)));
    std::size_t points = 0;
    for (auto _ : state) {
        const Scan result = scanner().scan(sensor, 1);
        points = result.cloud.size();
        benchmark::DoNotOptimize(points);
    }
    const double rays = double(sensor.width) * sensor.height;
    state.counters["rays_per_second"] = benchmark::Counter(rays * double(state.iterations()), benchmark::Counter::kIsRate);
    state.counters["points"] = double(points);
}

void build(benchmark::State& state)
{
    for (auto _ : state) {
        VirtualScanner instance(tabletop());
        benchmark::DoNotOptimize(instance);
    }
}

}  // namespace

int main(int argc, char** argv)
{
    const int cores = tbb::info::default_concurrency();
    std::vector<int> thread_counts;
    for (int t = 1; t < cores; t *= 2) thread_counts.push_back(t);
    thread_counts.push_back(cores);
    const std::pair<int, int> sizes[] = {{640, 480}, {4096, 4096}};
    for (const auto& [w, h] : sizes) {
        for (int t : thread_counts) {
            benchmark::RegisterBenchmark("scan", scan)
                ->Args({w, h, t})
                ->Unit(benchmark::kMillisecond)
                ->UseRealTime()
                ->Repetitions(w > 1000 ? 3 : 7)
                ->ReportAggregatesOnly(true);
        }
    }
    benchmark::RegisterBenchmark("build_embree_scene", build)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);

    benchmark::Initialize(&argc, argv);
    mfpc::bench::RecordingReporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);

    std::printf("\nVirtual scanner, %d cores seen by TBB (medians)\n", cores);
    for (const auto& [w, h] : sizes) {
        const std::string one = "scan/" + std::to_string(w) + "/" + std::to_string(h) + "/1";
        for (int t : thread_counts) {
            const std::string name = "scan/" + std::to_string(w) + "/" + std::to_string(h) + "/" + std::to_string(t);
            const double rate = reporter.counter(name, "rays_per_second");
            if (rate < 0) continue;
            std::printf("%5dx%-5d %3d threads: %8.2f M rays/s  ", w, h, t, rate / 1e6);
            reporter.print_ratio("speed-up over 1 thread", one, name);
        }
    }
    return 0;
}
