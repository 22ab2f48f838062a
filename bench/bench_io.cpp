// Cloud reading benchmark (issue: performance close to the limit). PCL 1.13's PCD reader
// (pcl::io::loadPCDFile into PointXYZRGBA, what its tutorials use) against ours (mfpc::read_cloud),
// on the same files, one thread, in this process: the shared Kinect scene as it is stored
// (binary_compressed), and the same cloud written by us as binary and ascii PCD. Printed after the
// runs from the medians: PCL / ours per encoding, and ours in MB/s of file.
// Run: build/release/bench/bench_io [--benchmark_repetitions=N]

#include <cstdio>
#include <filesystem>
#include <string>

#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <tbb/global_control.h>

#include "bench_support.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "shared_data.hpp"

namespace mfpc {
namespace {

struct Encoding {
    const char* name;
    CloudEncoding encoding;
};

const Encoding encodings[] = {{"binary_compressed", CloudEncoding::binary_compressed},
                              {"binary", CloudEncoding::binary},
                              {"ascii", CloudEncoding::ascii}};

// The files, written once: the shared scene itself for binary_compressed (as PCL wrote it), ours
// for the other two (organized, NaN holes kept, so both readers see 640x480 points).
const std::filesystem::path* file_of(int e)
{
    static const auto directory = [] {
        std::filesystem::path d = std::filesystem::temp_directory_path() / "mfpc_bench_io";
        std::filesystem::create_directories(d);
        return d;
    }();
    static std::filesystem::path files[3];
    static bool made = false;
    if (!made) {
        made = true;
        const auto scene = test::shared_data_dir() / "milk_cartoon_all_small_clorox.pcd";
        if (!std::filesystem::exists(scene)) return nullptr;
        files[0] = scene;
        const PointCloud cloud = read_cloud(scene);
        for (int k = 1; k < 3; ++k) {
            files[k] = directory / (std::string("scene_") + encodings[k].name + ".pcd");
            write_cloud(files[k], cloud, {encodings[k].encoding, true});
        }
    }
    return files[e].empty() ? nullptr : &files[e];
}

void BM_Pcl(benchmark::State& state, int e)
{
    const std::filesystem::path* path = file_of(e);
    if (!path) {
        state.SkipWithError("shared data missing");
        return;
    }
    pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
    for (auto _ : state) {
        pcl::PointCloud<pcl::PointXYZRGBA> cloud;
        if (pcl::io::loadPCDFile(path->string(), cloud) != 0) state.SkipWithError("PCL cannot read it");
        benchmark::DoNotOptimize(cloud.points.data());
    }
}

void BM_Ours(benchmark::State& state, int e)
{
    const std::filesystem::path* path = file_of(e);
    if (!path) {
        state.SkipWithError("shared data missing");
        return;
    }
    for (auto _ : state) {
        PointCloud cloud = read_cloud(*path);
        benchmark::DoNotOptimize(cloud.points.data());
    }
    state.counters["file_mb"] = double(std::filesystem::file_size(*path)) / 1e6;
}

void register_all()
{
    for (int e = 0; e < 3; ++e) {
        const int iterations = encodings[e].encoding == CloudEncoding::ascii ? 3 : 10;
        benchmark::RegisterBenchmark((std::string("Read/pcl/") + encodings[e].name).c_str(), BM_Pcl, e)
            ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(iterations);
        benchmark::RegisterBenchmark((std::string("Read/ours/") + encodings[e].name).c_str(), BM_Ours, e)
            ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(iterations);
    }
}

void print_summary(const bench::RecordingReporter& r)
{
    std::printf("\nReading a 640x480 Kinect scene, 1 thread (PCL 1.13 loadPCDFile / mfpc::read_cloud):\n");
    for (const Encoding& e : encodings) {
        r.print_ratio(std::string("  ") + e.name, std::string("Read/pcl/") + e.name, std::string("Read/ours/") + e.name);
        const double ms = r.time_ms(std::string("Read/ours/") + e.name);
        const double mb = r.counter(std::string("Read/ours/") + e.name, "file_mb");
        if (ms > 0 && mb > 0) std::printf("  %-56s %10.1f MB/s of file\n", (std::string("ours, ") + e.name).c_str(), mb / (ms / 1e3));
    }
}

}  // namespace
}  // namespace mfpc

int main(int argc, char** argv)
{
    // One thread: PCL's reader is serial, and so is ours.
    const tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    benchmark::Initialize(&argc, argv);
    mfpc::register_all();
    mfpc::bench::RecordingReporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    mfpc::print_summary(reporter);
    benchmark::Shutdown();
    return 0;
}
