// Recognition benchmarks (issue: recognition pipeline): PCL 1.13's correspondence-grouping pipeline
// (the PCL tutorial "3D Object Recognition based on Correspondence Grouping", step for step, in
// pcl_baseline.hpp) against ours (mfpc::recognize), on the same finite points of the same scene, at
// the same thread count, in this process. Printed after the runs, per scene and thread count, from
// the medians of the repetitions:
//  - end to end (scene side): PCL / ours plain (defaults: refine and verify on), PCL / ours
//    like-for-like (refine and verify off; PCL has neither), PCL / ours tutorial-matching (also
//    scene-to-model nearest neighbour, as PCL), PCL plain / ours mfpc (the scene foveated on
//    hand-placed structures) and PCL plain / ours auto (on the structures automatic placement
//    proposes, placement included);
//  - per stage: normals, keypoints, descriptors, lrf, match, group (and ours' place, foveate, verify);
//  - the model side (prepared once, outside the timed loops), PCL / ours;
//  - the match stage alone on ours' plain and mfpc descriptors: FLANN's exact kd-tree / our scan
//    (match_search; the same correspondences);
//  - counts (keypoints, correspondences) and the instances each pipeline found, with the
//    translation of each and its distance to the nearest ground-truth instance.
// Thread counts 1, 2, 4, ... up to the cores present (bench::thread_counts), with a table of each of
// ours' stages' time and efficiency (speed-up / threads) at each: ours under tbb::global_control,
// PCL's OMP classes (normals, SHOT) with setNumberOfThreads; the rest of PCL's pipeline (uniform
// sampling, BOARD, matching loop, Hough) is serial, as in the tutorial.
// Floors (machine_ceilings.hpp): each of ours' scene stages (defaults, plain and mfpc) against the
// bytes it must read and write once at the copy bandwidth and its formulas' arithmetic at the peak,
// both measured in this run at each thread count.
// Run: build/release/bench/bench_recognition [--benchmark_repetitions=N] [--benchmark_filter=...]

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <tbb/global_control.h>

#include "bench_support.hpp"
#include "machine_ceilings.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/pcl_adapter.hpp"
#include "mfpc/core/pose.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/kernels/shot.hpp"
#include "mfpc/kernels/voxel_grid.hpp"
#include "mfpc/recognition/described_scene.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/matching.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/placement.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "pcl_baseline.hpp"
#include "shared_data.hpp"

namespace mfpc {
namespace {

using bench::count_finite_descriptors;
using bench::count_finite_frames;
using bench::PclFeatures;
using bench::PclParams;
using bench::PclPoint;
using bench::PclStageTimes;
using bench::pcl_features;
using bench::pcl_recognize;
using bench::PclResult;

// ---------------------------------------------------------------------------------------------
// Inputs, loaded once.

struct Scene {
    std::string name;
    PointCloud cloud;
    pcl::PointCloud<PclPoint>::Ptr pcl_cloud;
    FoveationConfig config;
    std::string config_name;
    GroundTruth truth;
};

struct Inputs {
    PointCloud model_cloud;
    pcl::PointCloud<PclPoint>::Ptr pcl_model;
    Model model;          // ours, prepared once, with the built-in defaults
    RecognitionParams tutorial;  // examples/params/pcl_tutorial.json: PCL's parameters, no verification
    Model tutorial_model;        // ours, prepared once with the tutorial's model parameters
    PclFeatures pcl_model_features;  // PCL's, prepared once
    std::vector<Scene> scenes;
};

const Inputs* inputs()
{
    static std::unique_ptr<Inputs> loaded = []() -> std::unique_ptr<Inputs> {
        const auto data = test::shared_data_dir();
        const auto configs = std::filesystem::path(MFPC_SOURCE_DIR) / "examples/configs";
        for (const char* file : {"milk.pcd", "milk_cartoon_all_small_clorox.pcd", "milk_pair.pcd"}) {
            if (!std::filesystem::exists(data / file)) return nullptr;
        }
        auto in = std::make_unique<Inputs>();
        in->model_cloud = read_cloud(data / "milk.pcd");
        in->pcl_model.reset(new pcl::PointCloud<PclPoint>(to_pcl(in->model_cloud)));
        in->model = prepare_model(in->model_cloud, RecognitionParams{}.model, "milk.pcd");
        prepare_model_verification(in->model, RecognitionParams{});
        in->tutorial = read_recognition_params(std::filesystem::path(MFPC_SOURCE_DIR) / "examples/params/pcl_tutorial.json");
        in->tutorial_model = prepare_model(in->model_cloud, in->tutorial.model, "milk.pcd");
        prepare_model_verification(in->tutorial_model, in->tutorial);
        PclStageTimes ignored;
        in->pcl_model_features = pcl_features(in->pcl_model, PclParams{}.model_sampling, PclParams{}, 2, ignored);
        // milk_carton.json: one structure around the carton; milk_pair_two.json: one per carton
        // (examples/configs/README.md).
        const std::pair<const char*, const char*> scenes[] = {{"milk_cartoon_all_small_clorox", "milk_carton.json"},
                                                              {"milk_pair", "milk_pair_two.json"}};
        for (const auto& [name, config] : scenes) {
            Scene s;
            s.name = name;
            s.cloud = read_cloud(data / (std::string(name) + ".pcd"));
            s.pcl_cloud.reset(new pcl::PointCloud<PclPoint>(to_pcl(s.cloud)));
            s.config = read_foveation_config(configs / config);
            s.config_name = config;
            s.truth = read_ground_truth(data / (std::string(name) + ".gt.json"));
            in->scenes.push_back(std::move(s));
        }
        return in;
    }();
    return loaded.get();
}

#define MFPC_REQUIRE_INPUTS(state, var)                                                          \
    const Inputs* var = inputs();                                                                \
    if (!var) {                                                                                  \
        state.SkipWithError("shared data (milk.pcd, milk_cartoon_all_small_clorox.pcd, milk_pair.pcd) is absent"); \
        return;                                                                                  \
    }

// ---------------------------------------------------------------------------------------------
// What each run found, kept from its last iteration for the summary.

struct FoundInstance {
    Pose pose = Pose::Identity();
    double votes = -1;               // ours: interpolated Hough votes; PCL does not say (-1)
    std::size_t correspondences = 0;  // PCL: clustered correspondences; ours: the pose fit's inliers
};

struct Found {
    std::vector<std::pair<std::string, std::size_t>> counts;
    std::vector<FoundInstance> instances;
};

std::map<std::string, Found>& found_by_run()
{
    static std::map<std::string, Found> found;
    return found;
}

// ---------------------------------------------------------------------------------------------
// Benchmarks, one per scene; Arg: threads. Stage times go to counters (per-iteration averages), whose
// medians over the repetitions the reporter keeps.

// plain: the built-in defaults; tutorial: PCL's own parameters and algorithm choices, without
// refinement and verification (like for like with PCL); mfpc: the defaults on the foveated scene
// (hand-placed structures); auto: the defaults on the structures automatic placement proposes
// (the default strategy, segments), the placement timed with the run.
enum class Variant { plain, tutorial, mfpc, automatic };
constexpr const char* variant_names[] = {"plain", "tutorial", "mfpc", "auto"};

// Per-stage milliseconds of one run, as (counter name, value).
using StageTimes = std::vector<std::pair<const char*, double>>;

StageTimes stage_times(const PclStageTimes& t)
{
    return {{"normals", t.normals}, {"keypoints", t.keypoints}, {"descriptors", t.descriptors},
            {"lrf", t.lrf},         {"match", t.match},         {"group", t.group}};
}

StageTimes stage_times(const RecognitionTimings& t)
{
    return {{"place", t.place},     {"foveate", t.foveate}, {"normals", t.normals}, {"keypoints", t.keypoints},
            {"descriptors", t.descriptors}, {"lrf", t.lrf}, {"match", t.match},
            {"group", t.group},     {"verify", t.verify}};
}

// Sums the stage times of the iterations into counters (per-iteration averages), whose medians
// over the repetitions the reporter keeps.
class StageCounters {
public:
    void add(const StageTimes& times)
    {
        for (const auto& [stage, ms] : times) sums_[stage] += ms;
    }
    void report(benchmark::State& state) const
    {
        for (const auto& [stage, ms] : sums_) state.counters[stage] = benchmark::Counter(ms, benchmark::Counter::kAvgIterations);
    }

private:
    std::map<std::string, double> sums_;
};

std::string run_key(const std::string& pipeline, const Scene& scene, int threads)
{
    return pipeline + "/" + scene.name + "/threads/" + std::to_string(threads);
}

void BM_Pcl(benchmark::State& state, int scene_number)
{
    MFPC_REQUIRE_INPUTS(state, in);
    const Scene& scene = in->scenes[std::size_t(scene_number)];
    const int threads = int(state.range(0));
    StageCounters counters;
    PclResult last;
    for (auto _ : state) {
        last = pcl_recognize(in->pcl_model_features, scene.pcl_cloud, PclParams{}, threads);
        counters.add(stage_times(last.times));
    }
    counters.report(state);

    Found found;
    found.counts = {{"scene points", scene.pcl_cloud->size()},
                    {"keypoints (uniform sampling)", last.scene.keypoints->size()},
                    {"keypoints with finite SHOT", count_finite_descriptors(*last.scene.descriptors)},
                    {"keypoints with finite BOARD frame", count_finite_frames(*last.scene.frames)},
                    {"correspondences", last.correspondences->size()}};
    for (std::size_t i = 0; i < last.poses.size(); ++i) {
        FoundInstance f;
        f.pose.matrix() = last.poses[i];
        f.correspondences = last.clustered[i].size();
        found.instances.push_back(f);
    }
    found_by_run()[run_key("pcl", scene, threads)] = std::move(found);
}

void BM_Ours(benchmark::State& state, Variant variant, int scene_number)
{
    MFPC_REQUIRE_INPUTS(state, in);
    const Scene& scene = in->scenes[std::size_t(scene_number)];
    const int threads = int(state.range(0));
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    const RecognitionParams params = variant == Variant::tutorial ? in->tutorial : RecognitionParams{};
    const Model& model = variant == Variant::tutorial ? in->tutorial_model : in->model;
    SceneFoveation foveation;
    if (variant == Variant::mfpc) foveation = SceneFoveation{&scene.config, FoveationMode::mfpc, 0};

    StageCounters counters;
    RecognitionResult last;
    const Model* const models[] = {&model};
    for (auto _ : state) {
        if (variant == Variant::automatic) {
            // A placement that places nothing leaves the scene to the plain pipeline, as in `mfpc`.
            const PlacementResult placement = place_foveae(scene.cloud, models, params, PlacementParams{});
            const bool placed = !placement.config.structures.empty();
            foveation = SceneFoveation{placed ? &placement.config : nullptr,
                                       placed ? FoveationMode::mfpc : FoveationMode::none, 0};
            last = recognize(model, scene.cloud, params, foveation);
            last.timings.place = placement.ms;
        } else {
            last = recognize(model, scene.cloud, params, foveation);
        }
        counters.add(stage_times(last.timings));
    }
    counters.report(state);

    const RecognitionCounts& c = last.counts;
    Found found;
    found.counts = {{"scene points", c.scene_points},
                    {"scene points used (after foveation)", c.scene_points_used},
                    {"keypoints (uniform sampling)", c.scene_keypoints + c.scene_keypoints_invalid},
                    {"keypoints with valid SHOT and BOARD", c.scene_keypoints},
                    {"correspondences", c.correspondences},
                    {"instances before verification", c.instances_before_verification}};
    for (const Instance& instance : last.instances) {
        found.instances.push_back(FoundInstance{instance.transform, double(instance.votes), instance.correspondences.size()});
    }
    found_by_run()[run_key(std::string("ours_") + variant_names[int(variant)], scene, threads)] = std::move(found);
}

// The matching stage alone, scan against FLANN's exact kd-tree (the same correspondences), on the
// descriptors of ours plain or mfpc (built-in defaults), computed once and untimed.
const Features& scene_features(const Inputs& in, int scene_number, bool foveated)
{
    static std::map<std::pair<int, bool>, Features> computed;
    const auto key = std::pair{scene_number, foveated};
    if (const auto it = computed.find(key); it != computed.end()) return it->second;
    const Scene& scene = in.scenes[std::size_t(scene_number)];
    SceneFoveation foveation;
    if (foveated) foveation = SceneFoveation{&scene.config, FoveationMode::mfpc, 0};
    return computed[key] = recognize(in.model, scene.cloud, RecognitionParams{}, foveation).scene_features;
}

void BM_Match(benchmark::State& state, MatchSearch search, int scene_number, bool foveated)
{
    MFPC_REQUIRE_INPUTS(state, in);
    const Features& scene = scene_features(*in, scene_number, foveated);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
    MatchParams params = RecognitionParams{}.match;
    params.search = search;
    std::size_t found = 0;
    for (auto _ : state) {
        const std::vector<Correspondence> correspondences = match_descriptors(in->model.features, scene, params);
        found = correspondences.size();
        benchmark::DoNotOptimize(correspondences.data());
    }
    state.counters["correspondences"] = double(found);
}

void BM_ModelPcl(benchmark::State& state)
{
    MFPC_REQUIRE_INPUTS(state, in);
    PclStageTimes ignored;
    for (auto _ : state) {
        PclFeatures f = pcl_features(in->pcl_model, PclParams{}.model_sampling, PclParams{}, int(state.range(0)), ignored);
        benchmark::DoNotOptimize(f.descriptors->data());
    }
}

void BM_ModelOurs(benchmark::State& state)
{
    MFPC_REQUIRE_INPUTS(state, in);
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(state.range(0)));
    for (auto _ : state) {
        Model m = prepare_model(in->model_cloud, RecognitionParams{}.model, "milk.pcd");
        benchmark::DoNotOptimize(m.features.descriptors.data());
    }
}

using bench::thread_counts;
const char* scene_names[] = {"milk_cartoon_all_small_clorox", "milk_pair"};

void configure(benchmark::internal::Benchmark* b, int iterations)
{
    b->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(iterations);
}

void register_all()
{
    for (int t : thread_counts()) {
        configure(benchmark::RegisterBenchmark("Model/pcl/threads", BM_ModelPcl)->Arg(t), 2);
        configure(benchmark::RegisterBenchmark("Model/ours/threads", BM_ModelOurs)->Arg(t), 2);
        for (int s = 0; s < 2; ++s) {
            const std::string scene = scene_names[s];
            configure(benchmark::RegisterBenchmark(("Scene/pcl/" + scene + "/threads").c_str(), BM_Pcl, s)->Arg(t), 1);
            for (Variant v : {Variant::plain, Variant::tutorial, Variant::mfpc, Variant::automatic}) {
                const std::string name = "Scene/ours_" + std::string(variant_names[int(v)]) + "/" + scene + "/threads";
                configure(benchmark::RegisterBenchmark(name.c_str(), BM_Ours, v, s)->Arg(t), 1);
            }
            for (const bool foveated : {false, true})
                for (const MatchSearch search : {MatchSearch::kdtree, MatchSearch::scan}) {
                    const std::string name = "Match/" + std::string(to_string(search)) + "/" + scene + "/" +
                                             (foveated ? "mfpc" : "plain") + "/threads";
                    configure(benchmark::RegisterBenchmark(name.c_str(), BM_Match, search, s, foveated)->Arg(t), 3);
                }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Summary.

std::string bench_name(const std::string& pipeline, int scene, int threads)
{
    return "Scene/" + pipeline + "/" + scene_names[scene] + "/threads/" + std::to_string(threads);
}

void print_stage_row(const bench::RecordingReporter& r, const char* label, const std::string& pcl_name,
                     const char* pcl_stage, const std::vector<std::string>& ours_names, const char* ours_stage)
{
    const double p = pcl_stage ? r.counter(pcl_name, pcl_stage) : -1.0;
    std::printf("  %-12s", label);
    if (p >= 0) {
        std::printf(" %9.2f", p);
    } else {
        std::printf(" %9s", "-");
    }
    for (const std::string& ours : ours_names) {
        const double o = ours_stage ? r.counter(ours, ours_stage) : -1.0;
        if (o < 0) {
            std::printf(" %9s %8s", "-", "");
        } else if (p >= 0 && o > 0) {
            std::printf(" %9.2f %7.2fx", o, p / o);
        } else {
            std::printf(" %9.2f %8s", o, "");
        }
    }
    std::printf("\n");
}

void print_found(const std::string& label, const std::string& key, const GroundTruth& truth)
{
    const auto it = found_by_run().find(key);
    if (it == found_by_run().end()) {
        std::printf("  %-16s (not run)\n", label.c_str());
        return;
    }
    const Found& f = it->second;
    std::printf("  %-16s", label.c_str());
    for (const auto& [name, count] : f.counts) std::printf(" %s %zu;", name.c_str(), count);
    std::printf("\n  %-16s %zu instance(s)\n", "", f.instances.size());
    for (const FoundInstance& instance : f.instances) {
        const Eigen::Vector3f t = instance.pose.translation();
        int nearest = -1;
        float dt = 0, dr = 0;
        for (std::size_t g = 0; g < truth.instances.size(); ++g) {
            const float e = translation_error(instance.pose, truth.instances[g].transform);
            if (nearest < 0 || e < dt) {
                nearest = int(g);
                dt = e;
                dr = rotation_error_deg(instance.pose, truth.instances[g].transform);
            }
        }
        std::printf("  %-16s   t = (%7.4f, %7.4f, %7.4f)  %3zu corr  ", "", t.x(), t.y(), t.z(), instance.correspondences);
        if (instance.votes >= 0) {
            std::printf("votes %5.1f", instance.votes);
        } else {
            std::printf("%11s", "");
        }
        std::printf("  nearest truth #%d: %5.1f mm, %5.1f deg\n", nearest, 1000.0f * dt, dr);
    }
}

bool same_instances(const Found& a, const Found& b)
{
    if (a.instances.size() != b.instances.size()) return false;
    for (std::size_t i = 0; i < a.instances.size(); ++i) {
        if (translation_error(a.instances[i].pose, b.instances[i].pose) > 1e-4f) return false;
    }
    return true;
}

// ---------------------------------------------------------------------------------------------
// Floors and thread scaling of ours' scene stages.

using bench::Ceilings;
using bench::StageWork;

// The compulsory work of each of ours' scene stages with the built-in defaults, counted (untimed)
// on the surface the run describes: plain, the scene's voxels at the working resolution; mfpc, the
// foveated cloud. Bytes: each input read once and each output written once. Flops: the fewest
// operations of the stage's formulas per element, as below; searches, sorting, branches and
// bookkeeping count nothing, so the floor is low by design.
std::map<std::string, StageWork> ours_stage_work(const Inputs& in, int scene_number, bool foveated)
{
    const Scene& scene = in.scenes[std::size_t(scene_number)];
    const RecognitionParams params;
    SceneFoveation foveation;
    if (foveated) foveation = SceneFoveation{&scene.config, FoveationMode::mfpc, 0};
    const std::unique_ptr<DescribedScene> described = describe_scene(scene.cloud, params, foveation);
    std::vector<Point> resampled;
    if (!foveated) resampled = voxel_grid(described->scene->points, params.scene.resolution).centroids;
    const std::span<const Point> surface =
        foveated ? std::span<const Point>(described->foveated.cloud.points) : std::span<const Point>(resampled);
    const Features& features = described->features;
    // Normals are estimated for the surface points within some keypoint's support; frames and
    // descriptors read every point of each support.
    const float support = std::max(params.scene.lrf_radius, params.scene.shot_radius);
    const NeighborGrid grid(surface, support);
    const Neighborhoods supports = grid.radius_neighborhoods(features.keypoints, support);
    std::vector<std::uint8_t> has_normal(surface.size(), 0);
    for (const std::uint32_t i : supports.indices) has_normal[i] = 1;
    double normals = 0;
    for (const std::uint8_t h : has_normal) normals += h;
    const double support_points = double(supports.indices.size());
    const double keypoints = double(features.size());
    const double model_keypoints = double(in.model.features.size());
    const double correspondences =
        double(recognize(in.model, scene.cloud, params, foveation).counts.correspondences);
    constexpr double point = sizeof(Point), frame = 9 * sizeof(float), descriptor = shot_size * sizeof(float);
    const double scene_points = double(scene.cloud.size());
    const double k = params.scene.normal_k;

    std::map<std::string, StageWork> work;
    // Normal: per neighbour of the k, its squared distance in the search (8) and its share of the
    // centroid and the six covariance sums (3 + 12); then a symmetric 3x3 eigenvector (~100).
    // Plain: also the resampling, which reads the scene once and writes the voxels.
    work["normals"] = {normals * (point + point), normals * (k * 23.0 + 100.0)};
    if (!foveated) work["normals"].bytes += scene_points * point + double(surface.size()) * point;
    // Keypoints (mfpc; plain samples inside normals): the surface read once.
    if (foveated) work["keypoints"] = {double(surface.size()) * point, 0};
    // Foveation: the scene read once, the kept points written once.
    if (foveated) work["foveate"] = {scene_points * point + double(surface.size()) * point, 0};
    // BOARD: per support point, its distance (5), projection onto the tangent plane (8) and the
    // angle of its normal (5) plus the running maximum (2); the supports' points and normals read once.
    work["lrf"] = {normals * 2 * point + keypoints * frame, support_points * 20.0};
    // SHOT: per support point, its distance (5), coordinates in the frame (15), the cosine of its
    // normal (5), the bin and interpolation weights (~19) and eight weighted histogram updates (16).
    work["descriptors"] = {normals * 2 * point + keypoints * (frame + descriptor), support_points * 60.0};
    // Matching: every model descriptor against every scene descriptor, a 352-term dot product
    // each (the squared norms aside): 2 flops per term.
    work["match"] = {(model_keypoints + keypoints) * descriptor + correspondences * sizeof(Correspondence),
                     model_keypoints * keypoints * double(shot_size) * 2.0};
    // Grouping: per correspondence, its vote through the two frames (two 3x3 products and a
    // translation, 45) into 8 interpolated bins (16); keypoints and frames of both read.
    work["group"] = {correspondences * (sizeof(Correspondence) + 2 * (point + frame)), correspondences * 61.0};
    return work;
}

const char* const floor_stages[] = {"foveate", "normals", "keypoints", "lrf", "descriptors", "match", "group"};

void print_floors(const bench::RecordingReporter& r, const Inputs& in)
{
    std::printf("\n== ours' scene stages against this machine's floors (built-in defaults) ==\n"
                "floor = max(bytes read and written once / copy bandwidth, the formulas' flops / peak), both\n"
                "ceilings measured now with the stage's thread count; time / floor says how far the stage is from\n"
                "what the machine allows (verification: no floor, its ICP iterations vary per hypothesis)\n");
    std::map<int, Ceilings> ceilings;
    for (const int t : thread_counts()) {
        ceilings[t] = bench::measure_ceilings(t);
        std::printf("ceilings, %2d thread(s): copy %7.1f GB/s, peak %8.1f GFLOP/s (%s)\n", t, ceilings[t].bandwidth_gbs,
                    ceilings[t].gflops, ceilings[t].isa);
    }
    for (int s = 0; s < 2; ++s) {
        for (const bool foveated : {false, true}) {
            const std::map<std::string, StageWork> work = ours_stage_work(in, s, foveated);
            const char* variant = foveated ? "mfpc" : "plain";
            for (const int t : thread_counts()) {
                const std::string name = bench_name(std::string("ours_") + variant, s, t);
                std::printf("%s, %s, %d thread(s):\n  %-12s %9s %9s %10s %7s %9s %10s\n", scene_names[s], variant, t,
                            "stage", "ms", "floor ms", "time/floor", "bound", "MB", "MFLOP");
                for (const char* stage : floor_stages) {
                    const auto w = work.find(stage);
                    const double ms = r.counter(name, stage);
                    if (w == work.end() || ms <= 0) continue;
                    const double floor = bench::floor_ms(w->second, ceilings[t]);
                    std::printf("  %-12s %9.3f %9.4f %9.1fx %7s %9.2f %10.2f\n", stage, ms, floor, ms / floor,
                                bench::floor_bound(w->second, ceilings[t]), w->second.bytes * 1e-6,
                                w->second.flops * 1e-6);
                }
            }
        }
    }
}

void print_scaling(const bench::RecordingReporter& r)
{
    std::printf("\n== thread scaling of ours' stages (speed-up = 1-thread time / time; efficiency = speed-up / "
                "threads) ==\n");
    const char* const stages[] = {"place", "foveate", "normals", "keypoints", "lrf", "descriptors", "match", "group", "verify"};
    for (int s = 0; s < 2; ++s) {
        for (const char* variant : {"plain", "mfpc", "auto"}) {
            std::printf("%s, %s:\n  %-12s", scene_names[s], variant, "stage");
            for (const int t : thread_counts()) std::printf(" %8s %2d %5s", "ms at", t, "eff");
            std::printf("\n");
            auto row = [&](const char* label, auto time_at) {
                const double one = time_at(1);
                if (one <= 0) return;
                std::printf("  %-12s", label);
                for (const int t : thread_counts()) {
                    const double ms = time_at(t);
                    if (ms > 0) {
                        std::printf(" %11.2f %5.2f", ms, one / ms / t);
                    } else {
                        std::printf(" %11s %5s", "-", "");
                    }
                }
                std::printf("\n");
            };
            const std::string pipeline = std::string("ours_") + variant;
            for (const char* stage : stages)
                row(stage, [&](int t) { return r.counter(bench_name(pipeline, s, t), stage); });
            row("end to end", [&](int t) { return r.time_ms(bench_name(pipeline, s, t)); });
        }
    }
}

void print_summary(const bench::RecordingReporter& r, const Inputs& in)
{
    std::printf("\n== recognition: ratios of medians, PCL (correspondence-grouping tutorial) / ours ==\n");
    std::printf("ours plain: built-in defaults (larger supports, model-to-scene k=10 matching, refine + verify);\n"
                "tutorial: PCL's parameters (examples/params/pcl_tutorial.json), no refine/verify: like for like;\n"
                "mfpc: built-in defaults on the scene foveated on hand-placed structures; auto: on the structures\n"
                "automatic placement (segments) proposes, placement included\n"
                "stages: PCL normals are of every scene point; ours of the points in some keypoint's support, and\n"
                "include building the neighbour grids that lrf and descriptors use (PCL builds its kd-trees inside each\n"
                "stage). PCL's match stage builds its kd-tree; ours scans every pair (match_search \"scan\", the same\n"
                "correspondences as an exact kd-tree). Of PCL's stages only normals and descriptors use the 2nd thread.\n");
    for (int t : thread_counts()) {
        const std::string ts = std::to_string(t);
        std::printf("\n-- %d thread(s) --\n", t);
        r.print_ratio("model side (prepared once): PCL / ours", "Model/pcl/threads/" + ts, "Model/ours/threads/" + ts);
        for (int s = 0; s < 2; ++s) {
            const std::string pcl = bench_name("pcl", s, t);
            std::printf("%s (mfpc config %s):\n", scene_names[s], in.scenes[std::size_t(s)].config_name.c_str());
            r.print_ratio("  end to end: PCL / ours tutorial (like for like)", pcl, bench_name("ours_tutorial", s, t));
            r.print_ratio("  end to end: PCL / ours plain (defaults)", pcl, bench_name("ours_plain", s, t));
            r.print_ratio("  end to end: PCL plain / ours mfpc (defaults)", pcl, bench_name("ours_mfpc", s, t));
            r.print_ratio("  end to end: PCL plain / ours auto (placement included)", pcl, bench_name("ours_auto", s, t));
            const std::vector<std::string> ours = {bench_name("ours_tutorial", s, t), bench_name("ours_plain", s, t),
                                                   bench_name("ours_mfpc", s, t), bench_name("ours_auto", s, t)};
            std::printf("  %-12s %9s %9s %8s %9s %8s %9s %8s %9s %8s\n", "stage (ms)", "PCL", "tutorial", "PCL/tut",
                        "plain", "PCL/pl", "mfpc", "PCL/mfpc", "auto", "PCL/auto");
            print_stage_row(r, "place", pcl, nullptr, ours, "place");
            print_stage_row(r, "foveate", pcl, nullptr, ours, "foveate");
            print_stage_row(r, "normals", pcl, "normals", ours, "normals");
            print_stage_row(r, "keypoints", pcl, "keypoints", ours, "keypoints");
            print_stage_row(r, "descriptors", pcl, "descriptors", ours, "descriptors");
            print_stage_row(r, "lrf", pcl, "lrf", ours, "lrf");
            print_stage_row(r, "match", pcl, "match", ours, "match");
            print_stage_row(r, "group", pcl, "group", ours, "group");
            print_stage_row(r, "verify", pcl, nullptr, ours, "verify");
            for (const char* variant : {"plain", "mfpc"}) {
                const std::string tail = std::string("/") + scene_names[s] + "/" + variant + "/threads/" + ts;
                r.print_ratio(std::string("  match alone, ours ") + variant + ": FLANN exact kd-tree / scan",
                              "Match/kdtree" + tail, "Match/scan" + tail);
            }
        }
    }

    print_scaling(r);
    print_floors(r, in);

    std::printf("\n== what each found (last iteration; 1 thread, with a note where another count differs) ==\n");
    std::printf("model: PCL %zu keypoints (%zu with finite SHOT, %zu with finite BOARD); ours %zu valid of %zu\n",
                in.pcl_model_features.keypoints->size(), count_finite_descriptors(*in.pcl_model_features.descriptors),
                count_finite_frames(*in.pcl_model_features.frames), in.model.features.size(),
                in.model.features.candidates);
    for (int s = 0; s < 2; ++s) {
        const Scene& scene = in.scenes[std::size_t(s)];
        std::printf("%s: ground truth %zu instance(s)\n", scene.name.c_str(), scene.truth.instances.size());
        for (const char* pipeline : {"pcl", "ours_tutorial", "ours_plain", "ours_mfpc", "ours_auto"}) {
            print_found(pipeline, run_key(pipeline, scene, 1), scene.truth);
            const auto one = found_by_run().find(run_key(pipeline, scene, 1));
            for (const int t : thread_counts()) {
                const auto other = found_by_run().find(run_key(pipeline, scene, t));
                if (t == 1 || one == found_by_run().end() || other == found_by_run().end() ||
                    same_instances(one->second, other->second))
                    continue;
                std::printf("  %-16s NOTE: instances differ at %d threads:\n", "", t);
                print_found(std::string(pipeline) + " x" + std::to_string(t), run_key(pipeline, scene, t), scene.truth);
            }
        }
    }
}

}  // namespace
}  // namespace mfpc

int main(int argc, char** argv)
{
    // Defaults ahead of the user's flags (later flags win): 3 repetitions (about 2 minutes on 2
    // idle cores), aggregates only, and
    // interleaved repetitions so slow drifts of a shared machine hit PCL and ours alike.
    std::vector<char*> args(argv, argv + argc);
    std::string interleave = "--benchmark_enable_random_interleaving=true";
    std::string repetitions = "--benchmark_repetitions=3";
    std::string aggregates = "--benchmark_report_aggregates_only=true";
    args.insert(args.begin() + 1, {interleave.data(), repetitions.data(), aggregates.data()});
    argc = int(args.size());
    argv = args.data();
    benchmark::Initialize(&argc, argv);
    const mfpc::Inputs* in = mfpc::inputs();
    mfpc::register_all();
    mfpc::bench::RecordingReporter reporter;
    benchmark::RunSpecifiedBenchmarks(&reporter);
    if (in) {
        mfpc::print_summary(reporter, *in);
    } else {
        std::printf("shared data absent under %s: nothing measured\n", mfpc::test::shared_data_dir().c_str());
    }
    benchmark::Shutdown();
    return 0;
}
