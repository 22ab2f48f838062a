// Foveation benchmarks (issue: foveation engine). Each goal is a ratio measured in this process:
//  1. redundancy-treated foveation (labels + downsampling) of the real Kinect scene with two
//     structures, m = 3, on one core, against the reference Algorithm 1 (tests/support);
//  2. cost with 64 structures against the cost with 2;
//  3. a 10-million-point cloud re-foveated with moved foveae on a prebuilt index, against the
//     reference full scan, with the index build time and the crossover;
//  4. thread scaling of labelling and downsampling (efficiency = speedup / threads);
//  5. each foveation against its floor: the bytes it must read and write once at this machine's copy
//     bandwidth, measured in the same run.
// Run: build/release/bench/bench_foveate [--benchmark_filter=...]

#include <filesystem>
#include <memory>
#include <random>

#include <tbb/global_control.h>

#include "bench_support.hpp"
#include "machine_ceilings.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/kernels/foveate.hpp"
#include "reference_foveation.hpp"
#include "shared_data.hpp"

namespace mfpc {
namespace {

struct RealScene {
    PointCloud cloud;
    FoveationConfig config;  // the two cartons of examples/configs/milk_pair_two.json
    std::unique_ptr<PointIndex> index;
    // The same points without colours, for the ratio on coordinates alone (ours and the reference
    // both skip the colour work).
    PointCloud xyz;
    std::unique_ptr<PointIndex> xyz_index;
};

const RealScene* real_scene()
{
    static std::unique_ptr<RealScene> scene = [] {
        const auto path = test::shared_data_dir() / "milk_cartoon_all_small_clorox.pcd";
        if (!std::filesystem::exists(path)) return std::unique_ptr<RealScene>();
        auto s = std::make_unique<RealScene>();
        s->cloud = read_cloud(path);
        s->config = read_foveation_config(std::filesystem::path(MFPC_SOURCE_DIR) / "examples/configs/milk_pair_two.json");
        s->index = std::make_unique<PointIndex>(s->cloud);
        s->xyz = s->cloud;
        s->xyz.colors.clear();
        s->xyz_index = std::make_unique<PointIndex>(s->xyz);
        return s;
    }();
    return scene.get();
}

// The paper's way: every level of every structure scans the whole cloud (reference Algorithm 1),
// then the points are grouped into regions in index order.
FoveationRegions reference_regions(std::span<const Point> points, std::span<const FoveatedStructure> structures)
{
    const auto labels = reference::reference_mfpc_labels(points, structures);
    FoveationRegions regions;
    regions.structures = int(structures.size());
    regions.levels = structures[0].levels;
    regions.offsets.assign(std::size_t(regions.region_count()) + 1, 0);
    for (const RegionLabel& label : labels) {
        if (label.structure >= 0) ++regions.offsets[std::size_t(regions.region_id(label.structure, label.level)) + 1];
    }
    for (std::size_t r = 1; r < regions.offsets.size(); ++r) regions.offsets[r] += regions.offsets[r - 1];
    regions.members.resize(regions.offsets.back());
    std::vector<std::uint32_t> cursor(regions.offsets.begin(), regions.offsets.end() - 1);
    for (std::uint32_t i = 0; i < labels.size(); ++i) {
        if (labels[i].structure >= 0) {
            regions.members[cursor[std::size_t(regions.region_id(labels[i].structure, labels[i].level))]++] = i;
        }
    }
    return regions;
}

// Reference Algorithm 1 end to end: full-scan labels, then each region downsampled the obvious way,
// colours averaged with the points when the cloud has them (as ours, and PCL's VoxelGrid, do).
std::size_t reference_foveate(const PointCloud& cloud, const FoveationConfig& config)
{
    const FoveationRegions regions = reference_regions(cloud.points, config.structures);
    std::size_t kept = 0;
    for (int s = 0; s < regions.structures; ++s) {
        for (int k = 0; k <= regions.levels; ++k) {
            kept += reference::reference_downsample(cloud.points, regions.region(s, k),
                                                    config.structures[std::size_t(s)].density(k), config.downsample,
                                                    cloud.colors)
                        .points.size();
        }
    }
    return kept;
}

// Declares `var` = source(), or skips the benchmark when the shared scene is absent.
#define MFPC_REQUIRE_DATA(state, var, source)                                              \
    const auto* var = source();                                                            \
    if (!var) {                                                                            \
        state.SkipWithError("shared data milk_cartoon_all_small_clorox.pcd is absent");    \
        return;                                                                            \
    }
#define MFPC_REQUIRE_SCENE(state, scene) MFPC_REQUIRE_DATA(state, scene, real_scene)

// Ours on the real scene: the coloured cloud, or its points alone.
void run_real_scene(benchmark::State& state, bool colours)
{
    MFPC_REQUIRE_SCENE(state, scene);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
    const PointCloud& cloud = colours ? scene->cloud : scene->xyz;
    const PointIndex& index = colours ? *scene->index : *scene->xyz_index;
    for (auto _ : state) {
        FoveatedCloud result = foveate(cloud, index, scene->config, FoveationMode::mfpc);
        benchmark::DoNotOptimize(result.cloud.points.data());
    }
}

void BM_RealScene_Ours(benchmark::State& state) { run_real_scene(state, true); }
void BM_RealScene_OursXyz(benchmark::State& state) { run_real_scene(state, false); }

void BM_RealScene_OursLabels(benchmark::State& state)
{
    MFPC_REQUIRE_SCENE(state, scene);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
    for (auto _ : state) {
        FoveationRegions regions = foveation_regions(*scene->index, scene->config.structures, FoveationMode::mfpc);
        benchmark::DoNotOptimize(regions.members.data());
    }
}

void BM_RealScene_OursDownsample(benchmark::State& state)
{
    MFPC_REQUIRE_SCENE(state, scene);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
    const FoveationRegions regions = foveation_regions(*scene->index, scene->config.structures, FoveationMode::mfpc);
    for (auto _ : state) {
        FoveatedCloud result = downsample_regions(scene->cloud, regions, scene->config.structures, scene->config.downsample);
        benchmark::DoNotOptimize(result.cloud.points.data());
    }
}

void run_real_scene_reference(benchmark::State& state, bool colours)
{
    MFPC_REQUIRE_SCENE(state, scene);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
    const PointCloud& cloud = colours ? scene->cloud : scene->xyz;
    for (auto _ : state) benchmark::DoNotOptimize(reference_foveate(cloud, scene->config));
}

void BM_RealScene_Reference(benchmark::State& state) { run_real_scene_reference(state, true); }
void BM_RealScene_ReferenceXyz(benchmark::State& state) { run_real_scene_reference(state, false); }

void BM_RealScene_ReferenceLabels(benchmark::State& state)
{
    MFPC_REQUIRE_SCENE(state, scene);
    for (auto _ : state) {
        auto labels = reference::reference_mfpc_labels(scene->cloud.points, scene->config.structures);
        benchmark::DoNotOptimize(labels.data());
    }
}

void BM_RealScene_IndexBuild(benchmark::State& state)
{
    MFPC_REQUIRE_SCENE(state, scene);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
    for (auto _ : state) {
        PointIndex index(scene->cloud);
        benchmark::DoNotOptimize(index.leaves().data());
    }
}

// One foveation with no index at hand (what `mfpc recognize` does): no index is built; each point is
// labelled and keyed with where an index would list it, then downsampled.
void BM_RealScene_OneShot(benchmark::State& state)
{
    MFPC_REQUIRE_SCENE(state, scene);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
    for (auto _ : state) {
        FoveatedCloud result = foveate(scene->cloud, scene->config, FoveationMode::mfpc);
        benchmark::DoNotOptimize(result.cloud.points.data());
    }
}

// N structures over the same part of the scene: the bounding box of the two carton structures cut
// into N cells (2: 2x1x1, 64: 4x4x4), each cell's structure reaching 25% into its neighbours (so
// redundancy treatment has overlaps to resolve) with its fovea on the cell's central half. The
// points covered stay the same, so the ratio is the cost of the structures themselves.
std::vector<FoveatedStructure> grid_structures(const FoveationConfig& config, int count)
{
    Box region = config.structures[0].outer_box();
    for (const auto& s : config.structures) {
        region.min = region.min.cwiseMin(s.outer_box().min);
        region.max = region.max.cwiseMax(s.outer_box().max);
    }
    const Eigen::Vector3i cells = count == 2 ? Eigen::Vector3i(2, 1, 1) : Eigen::Vector3i(4, 4, 4);
    const Eigen::Vector3f cell = region.size().cwiseQuotient(cells.cast<float>());
    std::vector<FoveatedStructure> structures;
    for (int i = 0; i < cells.x(); ++i) {
        for (int j = 0; j < cells.y(); ++j) {
            for (int k = 0; k < cells.z(); ++k) {
                FoveatedStructure s = config.structures[0];
                s.outer_min = region.min + cell.cwiseProduct(Eigen::Vector3f(float(i), float(j), float(k))) - 0.25f * cell;
                s.outer_size = 1.5f * cell;
                s.fovea_size = 0.5f * cell;
                s.fovea_offset.setZero();
                structures.push_back(s);
            }
        }
    }
    return structures;
}

// The adversarial case: N jittered copies of the two carton structures (up to ±5 cm), every point
// covered by about N/2 structures.
std::vector<FoveatedStructure> stacked_structures(const FoveationConfig& config, int count)
{
    std::mt19937 rng(2018);
    std::uniform_real_distribution<float> shift(-0.05f, 0.05f);
    std::vector<FoveatedStructure> structures;
    for (int i = 0; i < count; ++i) {
        FoveatedStructure s = config.structures[std::size_t(i) % config.structures.size()];
        if (i >= int(config.structures.size())) s.outer_min += Eigen::Vector3f(shift(rng), shift(rng), shift(rng));
        structures.push_back(s);
    }
    return structures;
}

void BM_Structures_Ours(benchmark::State& state)
{
    MFPC_REQUIRE_SCENE(state, scene);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
    const int count = int(state.range(0));
    FoveationConfig config = scene->config;
    config.structures =
        state.range(1) ? stacked_structures(scene->config, count) : grid_structures(scene->config, count);
    for (auto _ : state) {
        FoveatedCloud result = foveate(scene->cloud, *scene->index, config, FoveationMode::mfpc);
        benchmark::DoNotOptimize(result.cloud.points.data());
    }
}

void BM_Structures_ReferenceLabels(benchmark::State& state)
{
    MFPC_REQUIRE_SCENE(state, scene);
    const auto structures = grid_structures(scene->config, int(state.range(0)));
    for (auto _ : state) {
        auto labels = reference::reference_mfpc_labels(scene->cloud.points, structures);
        benchmark::DoNotOptimize(labels.data());
    }
}

// About 10 million points: the real scene tiled 6 x 7 times on the floor plane, 2.5 m apart.
struct LargeCloud {
    PointCloud cloud;
    std::unique_ptr<PointIndex> index;
    std::vector<std::vector<FoveatedStructure>> foveae;  // the two-carton structures, moved per tile
};

constexpr int tiles_x = 6;
constexpr int tiles_z = 7;

const LargeCloud* large_cloud()
{
    static std::unique_ptr<LargeCloud> large = [] {
        const RealScene* scene = real_scene();
        if (!scene) return std::unique_ptr<LargeCloud>();
        auto l = std::make_unique<LargeCloud>();
        for (int tx = 0; tx < tiles_x; ++tx) {
            for (int tz = 0; tz < tiles_z; ++tz) {
                const Eigen::Vector3f offset(2.5f * float(tx), 0.0f, 2.5f * float(tz));
                for (const Point& p : scene->cloud.points) l->cloud.points.push_back(p + offset);
                if (l->foveae.size() < 8) {
                    auto structures = scene->config.structures;
                    for (auto& s : structures) s.outer_min += offset;
                    l->foveae.push_back(structures);
                }
            }
        }
        l->cloud.width = std::uint32_t(l->cloud.size());
        l->index = std::make_unique<PointIndex>(l->cloud);
        return l;
    }();
    return large.get();
}

#define MFPC_REQUIRE_LARGE(state, large) MFPC_REQUIRE_DATA(state, large, large_cloud)

void BM_Large_IndexBuild(benchmark::State& state)
{
    MFPC_REQUIRE_LARGE(state, large);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
    for (auto _ : state) {
        PointIndex index(large->cloud);
        benchmark::DoNotOptimize(index.leaves().data());
    }
    state.counters["points"] = double(large->cloud.size());
}

// Each iteration moves the foveae to the next tile and foveates again on the same index.
void BM_Large_Ours(benchmark::State& state)
{
    MFPC_REQUIRE_LARGE(state, large);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
    FoveationConfig config;
    config.downsample = Downsample::voxel;
    std::size_t move = 0;
    for (auto _ : state) {
        config.structures = large->foveae[move++ % large->foveae.size()];
        FoveatedCloud result = foveate(large->cloud, *large->index, config, FoveationMode::mfpc);
        benchmark::DoNotOptimize(result.cloud.points.data());
    }
}

// The full scan: labels by reference Algorithm 1, then the same downsampling kernel as ours, so the
// ratio is what the index buys.
void BM_Large_FullScan(benchmark::State& state)
{
    MFPC_REQUIRE_LARGE(state, large);
    tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
    std::size_t move = 0;
    for (auto _ : state) {
        const auto& structures = large->foveae[move++ % large->foveae.size()];
        const FoveationRegions regions = reference_regions(large->cloud.points, structures);
        FoveatedCloud result = downsample_regions(large->cloud, regions, structures, Downsample::voxel);
        benchmark::DoNotOptimize(result.cloud.points.data());
    }
}

// Repetitions give medians; slow benchmarks run a fixed number of iterations per repetition.
void configure(benchmark::internal::Benchmark* b, int repetitions = 7, int iterations = 0)
{
    b->Unit(benchmark::kMillisecond)->Repetitions(repetitions)->ReportAggregatesOnly(true)->UseRealTime();
    if (iterations > 0) {
        b->Iterations(iterations);
    } else {
        b->MinTime(0.1);
    }
}

using bench::thread_counts;

void register_all()
{
    for (int t : thread_counts()) {
        configure(benchmark::RegisterBenchmark("RealScene/ours/threads", BM_RealScene_Ours)->Arg(t));
        configure(benchmark::RegisterBenchmark("RealScene/ours_xyz/threads", BM_RealScene_OursXyz)->Arg(t));
        configure(benchmark::RegisterBenchmark("RealScene/ours_labels/threads", BM_RealScene_OursLabels)->Arg(t));
        configure(benchmark::RegisterBenchmark("RealScene/ours_downsample/threads", BM_RealScene_OursDownsample)->Arg(t));
        configure(benchmark::RegisterBenchmark("RealScene/index_build/threads", BM_RealScene_IndexBuild)->Arg(t));
        configure(benchmark::RegisterBenchmark("RealScene/one_shot/threads", BM_RealScene_OneShot)->Arg(t));
    }
    configure(benchmark::RegisterBenchmark("RealScene/reference", BM_RealScene_Reference), 5);
    configure(benchmark::RegisterBenchmark("RealScene/reference_xyz", BM_RealScene_ReferenceXyz), 5);
    configure(benchmark::RegisterBenchmark("RealScene/reference_labels", BM_RealScene_ReferenceLabels), 5);
    for (int n : {2, 64}) {
        configure(benchmark::RegisterBenchmark("Structures/ours_grid", BM_Structures_Ours)->Args({n, 0}));
        configure(benchmark::RegisterBenchmark("Structures/ours_stacked", BM_Structures_Ours)->Args({n, 1}));
        configure(benchmark::RegisterBenchmark("Structures/reference_labels_grid", BM_Structures_ReferenceLabels)->Arg(n), 3);
    }
    for (int t : thread_counts()) {
        configure(benchmark::RegisterBenchmark("Large/index_build/threads", BM_Large_IndexBuild)->Arg(t), 3, 1);
        configure(benchmark::RegisterBenchmark("Large/ours/threads", BM_Large_Ours)->Arg(t));
    }
    configure(benchmark::RegisterBenchmark("Large/full_scan", BM_Large_FullScan), 3, 2);
}

// The compulsory work of a foveation: the points it must read (every point of the cloud when no
// index says which are covered, else the regions' members) and the kept cloud it writes, each once;
// the arithmetic is the voxel centroids' sums (3 coordinates and 3 colour channels per member), far
// below the bytes' time.
bench::StageWork foveation_work(const PointCloud& cloud, const FoveatedCloud& kept, bool whole_cloud)
{
    const double per_point = sizeof(Point) + (cloud.colors.empty() ? 0.0 : double(sizeof(Rgb)));
    const double read = double(whole_cloud ? cloud.size() : kept.points_before_downsampling) * per_point;
    const double written =
        double(kept.cloud.size()) * (per_point + sizeof(std::uint32_t) + sizeof(RegionLabel));
    return {read + written, double(kept.points_before_downsampling) * 6.0};
}

void print_floors(const bench::RecordingReporter& r)
{
    const RealScene* scene = real_scene();
    const LargeCloud* large = large_cloud();
    if (!scene || !large) return;
    std::printf("\n== foveation against this machine's floor (bytes read and written once / copy bandwidth) ==\n");
    const FoveatedCloud one_shot = foveate(scene->cloud, scene->config, FoveationMode::mfpc);
    FoveationConfig moved;
    moved.downsample = Downsample::voxel;
    moved.structures = large->foveae[0];
    const FoveatedCloud tile = foveate(large->cloud, *large->index, moved, FoveationMode::mfpc);
    const std::pair<const char*, bench::StageWork> stages[] = {
        {"RealScene/one_shot", foveation_work(scene->cloud, one_shot, true)},
        {"RealScene/ours", foveation_work(scene->cloud, one_shot, false)},
        {"Large/ours", foveation_work(large->cloud, tile, false)}};
    for (const int t : thread_counts()) {
        const bench::Ceilings c = bench::measure_ceilings(t);
        std::printf("%2d thread(s), copy %.1f GB/s:\n", t, c.bandwidth_gbs);
        for (const auto& [name, work] : stages) {
            const double ms = r.time_ms(std::string(name) + "/threads/" + std::to_string(t));
            if (ms <= 0) continue;
            const double floor = bench::floor_ms(work, c);
            std::printf("  %-20s %9.3f ms, floor %8.4f ms (%6.2f MB), time / floor %7.1fx\n", name, ms, floor,
                        work.bytes * 1e-6, ms / floor);
        }
    }
}

void print_summary(const bench::RecordingReporter& r)
{
    std::printf("\n== foveation: ratios of medians (baseline / ours) ==\n");
    r.print_ratio("real scene, 2 structures, 1 core: reference / ours (goal: at least 10)", "RealScene/reference",
                  "RealScene/ours/threads/1");
    r.print_ratio("real scene, 2 structures, 1 core, coordinates only: reference / ours", "RealScene/reference_xyz",
                  "RealScene/ours_xyz/threads/1");
    r.print_ratio("real scene labels only, 1 core: reference / ours", "RealScene/reference_labels",
                  "RealScene/ours_labels/threads/1");
    std::printf("real scene, ours on 1 core, with colours: %.3f ms (goal: at most 3 ms)\n",
                r.time_ms("RealScene/ours/threads/1"));
    r.print_ratio("real scene, 1 core: reference / ours one-shot (no index at hand)",
                  "RealScene/reference", "RealScene/one_shot/threads/1");
    r.print_ratio("real scene, 1 core: index of the whole scene / ours one-shot", "RealScene/index_build/threads/1",
                  "RealScene/one_shot/threads/1");
    r.print_ratio("structures, grid: ours 64 / ours 2 (goal: at most 3)", "Structures/ours_grid/64/0",
                  "Structures/ours_grid/2/0");
    r.print_ratio("structures, stacked: ours 64 / ours 2", "Structures/ours_stacked/64/1", "Structures/ours_stacked/2/1");
    r.print_ratio("structures, grid: reference labels 64 / 2 (paper: linear)", "Structures/reference_labels_grid/64",
                  "Structures/reference_labels_grid/2");
    r.print_ratio("10M points, moved foveae, 1 core: full scan / ours", "Large/full_scan", "Large/ours/threads/1");
    const double build = r.time_ms("Large/index_build/threads/1");
    const double scan = r.time_ms("Large/full_scan");
    const double ours = r.time_ms("Large/ours/threads/1");
    if (build > 0 && scan > ours && ours > 0) {
        std::printf("10M points: index build %.1f ms (1 core); pays off after %.2f foveations "
                    "(build / (full scan - ours))\n", build, build / (scan - ours));
    }
    std::printf("\n== thread scaling (efficiency = speedup / threads) ==\n");
    for (const char* name : {"RealScene/ours", "RealScene/ours_xyz", "RealScene/ours_labels", "RealScene/ours_downsample",
                             "RealScene/index_build", "RealScene/one_shot", "Large/ours", "Large/index_build"}) {
        const double one = r.time_ms(std::string(name) + "/threads/1");
        for (int t : thread_counts()) {
            const double tt = r.time_ms(std::string(name) + "/threads/" + std::to_string(t));
            if (one > 0 && tt > 0) {
                std::printf("%-28s threads %3d: %9.3f ms  speedup %5.2f  efficiency %4.2f\n", name, t, tt, one / tt,
                            one / tt / t);
            }
        }
    }
}

}  // namespace
}  // namespace mfpc

int main(int argc, char** argv)
{
    // Repetitions of different benchmarks interleave, so slow drifts of a shared machine hit the
    // baseline and ours alike (override with --benchmark_enable_random_interleaving=false).
    std::vector<char*> args(argv, argv + argc);
    std::string interleave = "--benchmark_enable_random_interleaving=true";
    args.insert(args.begin() + 1, interleave.data());
    argc = int(args.size());
    argv = args.data();
    benchmark::Initialize(&argc, argv);
    mfpc::register_all();
    mfpc::bench::RecordingReporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    mfpc::print_summary(reporter);
    mfpc::print_floors(reporter);
    benchmark::Shutdown();
    return 0;
}
