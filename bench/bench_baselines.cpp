// Recognition baselines side by side: ours (mfpc::recognize, built-in defaults), PCL 1.13's
// correspondence-grouping tutorial (pcl_baseline.hpp) and Open3D 0.16's FPFH + RANSAC + ICP global
// registration repeated per instance (open3d_baseline.hpp), on the shared real Kinect scenes, all
// at 2 threads, in this process. Printed per scene and per tool: the instances found, false and
// missed (mfpc::evaluate's rule for all three: within 2 cm and 10 degrees of an unclaimed true
// instance, or 2 cm and the same visible surface; in a negative scene every instance is false), the median scene time over the
// repetitions, and Open3D / ours and PCL / ours of those medians. The model side (describing the
// model) is timed apart, with the same repetitions.
//
// Scene time, per tool, from its own cloud type in memory to its poses:
//  - ours: wall clock around recognize() (the span its result.timings.total measures from inside);
//  - PCL: wall clock around pcl_recognize(), on a PCL cloud converted before the clock starts;
//  - Open3D: open3d_recognize()'s total, which starts after the copy into Open3D's cloud (that
//    copy is printed apart, as "convert").
// Threads: ours under tbb::global_control; PCL's OMP classes (normals, SHOT) with
// setNumberOfThreads, the rest of its pipeline is serial as in the tutorial; Open3D's OpenMP with
// omp_set_num_threads (and its few TBB loops under the same global_control).
//
// Run: build/release/bench/bench_baselines [--repetitions N]   (N >= 1, default 3)

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <pcl/console/print.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <tbb/global_control.h>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/pcl_adapter.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "open3d_baseline.hpp"
#include "pcl_baseline.hpp"
#include "shared_data.hpp"

namespace mfpc::bench {
namespace {

constexpr int threads = 2;

using Clock = std::chrono::steady_clock;

double elapsed_ms(Clock::time_point since)
{
    return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

double median(std::vector<double> values)
{
    if (values.empty()) return 0;
    std::sort(values.begin(), values.end());
    const std::size_t middle = values.size() / 2;
    return values.size() % 2 == 1 ? values[middle] : 0.5 * (values[middle - 1] + values[middle]);
}

enum Tool { ours, pcl_tool, open3d_tool, tool_count };
constexpr const char* tool_names[tool_count] = {"ours", "PCL", "Open3D"};

struct SceneSpec {
    const char* name;
    bool positive;  // has <name>.gt.json; a negative has no instance
};

constexpr SceneSpec scene_specs[] = {
    {"milk_cartoon_all_small_clorox", true}, {"milk_pair", true}, {"milk_near_far", true},
    {"milk_floor", true},                    {"floor_laptop", false}, {"office1", false},
};

struct Scene {
    SceneSpec spec;
    PointCloud cloud;
    pcl::PointCloud<PclPoint>::Ptr pcl_cloud;
    GroundTruth truth;  // empty for a negative
};

// One tool's run on one scene: its scene time, stage times and the instances' transforms, scored.
struct Run {
    double ms = 0;
    std::vector<std::pair<const char*, double>> stages;
    Evaluation score;
    std::size_t instances = 0;
};

// Every repetition of each (scene, tool).
struct Runs {
    std::vector<Run> of[tool_count];
};

// Only the instances' transforms: what evaluate reads of a result for instance scoring (its
// correspondence scoring reads correspondences and scene features, left empty here).
RecognitionResult transforms_only(const std::vector<Pose>& poses)
{
    RecognitionResult result;
    for (const Pose& pose : poses) {
        Instance instance;
        instance.transform = pose;
        result.instances.push_back(std::move(instance));
    }
    return result;
}

Run run_ours(const Model& model, const Scene& scene)
{
    Run run;
    const auto start = Clock::now();
    const RecognitionResult result = recognize(model, scene.cloud, RecognitionParams{}, {});
    run.ms = elapsed_ms(start);
    const RecognitionTimings& t = result.timings;
    run.stages = {{"normals", t.normals}, {"keypoints", t.keypoints}, {"lrf", t.lrf}, {"descriptors", t.descriptors},
                  {"match", t.match},     {"group", t.group},         {"verify", t.verify}};
    run.score = evaluate(result, model, scene.truth);
    run.instances = result.instances.size();
    return run;
}

Run run_pcl(const PclFeatures& pcl_model, const Model& model, const Scene& scene)
{
    Run run;
    const auto start = Clock::now();
    const PclResult result = pcl_recognize(pcl_model, scene.pcl_cloud, PclParams{}, threads);
    run.ms = elapsed_ms(start);
    const PclStageTimes& t = result.times;
    run.stages = {{"normals", t.normals}, {"keypoints", t.keypoints}, {"lrf", t.lrf},
                  {"descriptors", t.descriptors}, {"match", t.match}, {"group", t.group}};
    std::vector<Pose> poses;
    for (const Eigen::Matrix4f& m : result.poses) {
        Pose pose = Pose::Identity();
        pose.matrix() = m;
        poses.push_back(pose);
    }
    run.score = evaluate(transforms_only(poses), model, scene.truth);
    run.instances = poses.size();
    return run;
}

Run run_open3d(const Open3dModel& open3d_model, const Model& model, const Scene& scene)
{
    Run run;
    const Open3dResult result = open3d_recognize(open3d_model, scene.cloud, Open3dParams{}, threads);
    const Open3dStageTimes& t = result.times;
    run.ms = t.total;
    run.stages = {{"convert (not in time)", t.convert}, {"downsample", t.downsample}, {"normals", t.normals},
                  {"fpfh", t.fpfh}, {"ransac", t.ransac}, {"icp", t.icp}, {"remove", t.remove}};
    std::vector<Pose> poses;
    for (const Open3dInstance& instance : result.instances) poses.push_back(instance.pose);
    run.score = evaluate(transforms_only(poses), model, scene.truth);
    run.instances = poses.size();
    return run;
}

std::string counts(const Evaluation& e)
{
    return std::to_string(e.instances_true) + "/" + std::to_string(e.instances_false) + "/" +
           std::to_string(e.instances_missed);
}

// found/false/missed: one value when every repetition agrees, else each repetition's in order.
std::string counts(const std::vector<Run>& runs)
{
    std::string first = counts(runs.front().score);
    const bool same = std::all_of(runs.begin(), runs.end(), [&](const Run& r) { return counts(r.score) == first; });
    if (same) return first;
    std::string all;
    for (const Run& r : runs) all += (all.empty() ? "" : " ") + counts(r.score);
    return all;
}

double median_ms(const std::vector<Run>& runs)
{
    std::vector<double> ms;
    for (const Run& r : runs) ms.push_back(r.ms);
    return median(ms);
}

void print_stages(const char* tool, const std::vector<Run>& runs)
{
    std::printf("    %-7s stages (median ms):", tool);
    for (std::size_t s = 0; s < runs.front().stages.size(); ++s) {
        std::vector<double> ms;
        for (const Run& r : runs) ms.push_back(r.stages[s].second);
        std::printf(" %s %.1f;", runs.front().stages[s].first, median(ms));
    }
    std::printf("\n");
}

// Each instance of the last repetition: the true instance it matched (or "false") and its errors
// to the nearest true instance.
void print_instances(const char* tool, const Run& run)
{
    if (run.score.instance_match.empty()) return;
    std::printf("    %-7s instances (last repetition):", tool);
    for (std::size_t i = 0; i < run.score.instance_match.size(); ++i) {
        const int match = run.score.instance_match[i];
        if (match >= 0) {
            std::printf(" truth #%d", match);
        } else {
            std::printf(" false");
        }
        if (std::isfinite(run.score.position_error[i])) {
            std::printf(" (%.1f mm, %.1f deg);", 1000.0 * run.score.position_error[i],
                        double(run.score.rotation_error_deg[i]));
        } else {
            std::printf(";");
        }
    }
    std::printf("\n");
}

int parse_repetitions(int argc, char** argv)
{
    int repetitions = 3;
    for (int i = 1; i < argc; ++i) {
        const std::string_view arg = argv[i];
        std::string value;
        if (arg == "--repetitions" && i + 1 < argc) {
            value = argv[++i];
        } else if (arg.starts_with("--repetitions=")) {
            value = std::string(arg.substr(std::string_view("--repetitions=").size()));
        } else {
            return -1;
        }
        char* end = nullptr;
        const long n = std::strtol(value.c_str(), &end, 10);
        if (value.empty() || *end != '\0' || n < 1 || n > 1000) return -1;
        repetitions = int(n);
    }
    return repetitions;
}

int run(int repetitions)
{
    const std::filesystem::path data = test::shared_data_dir();
    std::vector<std::string> files = {"milk.pcd"};
    for (const SceneSpec& spec : scene_specs) {
        files.push_back(std::string(spec.name) + ".pcd");
        if (spec.positive) files.push_back(std::string(spec.name) + ".gt.json");
    }
    for (const std::string& file : files) {
        if (!std::filesystem::exists(data / file)) {
            std::printf("bench_baselines: shared data absent (no %s under %s; set MFPC_DATA_DIR): nothing measured\n",
                        file.c_str(), data.c_str());
            return 0;
        }
    }

    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
    // PCL's SHOT prints a line for each keypoint whose frame or neighbourhood is invalid: thousands
    // per scene, nothing this summary uses (such keypoints get NaN descriptors, which the matching
    // skips).
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
    const PointCloud model_cloud = read_cloud(data / "milk.pcd");
    const pcl::PointCloud<PclPoint>::Ptr pcl_model(new pcl::PointCloud<PclPoint>(to_pcl(model_cloud)));
    std::vector<Scene> scenes;
    for (const SceneSpec& spec : scene_specs) {
        Scene scene{spec, read_cloud(data / (std::string(spec.name) + ".pcd")), nullptr, {}};
        scene.pcl_cloud.reset(new pcl::PointCloud<PclPoint>(to_pcl(scene.cloud)));
        if (spec.positive) scene.truth = read_ground_truth(data / (std::string(spec.name) + ".gt.json"));
        scenes.push_back(std::move(scene));
    }

    // The model side, each tool's repeated as often as its scene side; the last one is used.
    std::vector<double> model_ms[tool_count];
    Model model;
    PclFeatures pcl_model_features;
    Open3dModel open3d_model;
    for (int r = 0; r < repetitions; ++r) {
        auto start = Clock::now();
        model = prepare_model(model_cloud, RecognitionParams{}.model, "milk.pcd");
        prepare_model_verification(model, RecognitionParams{});
        model_ms[ours].push_back(elapsed_ms(start));

        start = Clock::now();
        PclStageTimes ignored;
        pcl_model_features = pcl_features(pcl_model, PclParams{}.model_sampling, PclParams{}, threads, ignored);
        model_ms[pcl_tool].push_back(elapsed_ms(start));

        open3d_model = open3d_prepare_model(model_cloud, Open3dParams{}, threads);
        model_ms[open3d_tool].push_back(open3d_model.times.total);
    }

    // Repetitions outermost, tools innermost, so a slow drift of a shared machine hits all alike.
    std::vector<Runs> runs(scenes.size());
    for (int r = 0; r < repetitions; ++r) {
        for (std::size_t s = 0; s < scenes.size(); ++s) {
            runs[s].of[ours].push_back(run_ours(model, scenes[s]));
            runs[s].of[pcl_tool].push_back(run_pcl(pcl_model_features, model, scenes[s]));
            runs[s].of[open3d_tool].push_back(run_open3d(open3d_model, model, scenes[s]));
        }
    }

    const Open3dParams o3d;
    std::printf("== recognition baselines: %d thread(s), median of %d repetition(s), data %s ==\n", threads,
                repetitions, data.c_str());
    std::printf("ours: mfpc::recognize, built-in defaults (plain, no foveation); time: wall clock around the call\n"
                "PCL: 1.13 correspondence-grouping tutorial (normals k=%d, uniform sampling %.3f model / %.3f scene,\n"
                "     SHOT %.3f, BOARD %.3f, Hough bin %.3f threshold %.0f); time: wall clock around pcl_recognize\n"
                "Open3D: 0.16 voxel %.3f, FPFH + RANSAC (%d iterations, %.3f) + point-to-plane ICP (%.4f m), repeated\n"
                "     per instance while ICP fitness >= %.2f (at most %d), removing scene points within %.3f m of each\n"
                "     placed model; time: open3d_recognize's total (the copy into Open3D's cloud apart)\n"
                "scoring: mfpc::evaluate, within 2 cm and 10 deg (or the same visible surface) of an unclaimed\n"
                "true instance; counts are found/false/missed, one per repetition where they differ\n",
                PclParams{}.normal_k, double(PclParams{}.model_sampling), double(PclParams{}.scene_sampling),
                double(PclParams{}.shot_radius), double(PclParams{}.lrf_radius), double(PclParams{}.hough_bin),
                double(PclParams{}.hough_threshold), o3d.voxel, o3d.ransac_iterations, o3d.ransac_confidence,
                o3d.icp_distance * o3d.voxel, o3d.min_fitness, o3d.max_instances, o3d.removal_distance);

    std::printf("\nmodel side (milk.pcd, %zu points; median ms): ours %.1f (%zu keypoints), PCL %.1f (%zu keypoints), "
                "Open3D %.1f (%zu points after down-sampling)\n",
                model_cloud.size(), median(model_ms[ours]), model.features.size(), median(model_ms[pcl_tool]),
                pcl_model_features.keypoints->size(), median(model_ms[open3d_tool]), open3d_model.points);

    std::printf("\n%-30s %5s  %-16s %-16s %-16s %10s %10s %10s %9s %9s\n", "scene", "truth", "ours f/f/m",
                "PCL f/f/m", "Open3D f/f/m", "ours ms", "PCL ms", "Open3D ms", "PCL/ours", "O3D/ours");
    for (std::size_t s = 0; s < scenes.size(); ++s) {
        const Runs& r = runs[s];
        const double ms[tool_count] = {median_ms(r.of[ours]), median_ms(r.of[pcl_tool]), median_ms(r.of[open3d_tool])};
        std::printf("%-30s %5zu  %-16s %-16s %-16s %10.1f %10.1f %10.1f %8.2fx %8.2fx\n", scenes[s].spec.name,
                    scenes[s].truth.instances.size(), counts(r.of[ours]).c_str(), counts(r.of[pcl_tool]).c_str(),
                    counts(r.of[open3d_tool]).c_str(), ms[ours], ms[pcl_tool], ms[open3d_tool],
                    ms[pcl_tool] / ms[ours], ms[open3d_tool] / ms[ours]);
    }

    std::printf("\nper scene: stage medians and the last repetition's instances\n");
    for (std::size_t s = 0; s < scenes.size(); ++s) {
        std::printf("  %s (%zu finite points, %zu true instance(s))\n", scenes[s].spec.name, scenes[s].cloud.size(),
                    scenes[s].truth.instances.size());
        for (int t = 0; t < tool_count; ++t) {
            print_stages(tool_names[t], runs[s].of[t]);
            print_instances(tool_names[t], runs[s].of[t].back());
        }
    }
    return 0;
}

}  // namespace
}  // namespace mfpc::bench

int main(int argc, char** argv)
{
    const int repetitions = mfpc::bench::parse_repetitions(argc, argv);
    if (repetitions < 1) {
        std::fprintf(stderr, "usage: %s [--repetitions N]   (N from 1 to 1000, default 3)\n", argv[0]);
        return 2;
    }
    try {
        return mfpc::bench::run(repetitions);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_baselines: %s\n", e.what());
        return 1;
    }
}
