// The reports of recognize, foveate and experiment on small results made by hand: what each
// document says follows from the result it was given (positions from the transforms, means and
// reductions from the runs, region files from the labels), and a result written as JSON reads
// back as the same poses.
#include <algorithm>
#include <cmath>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mfpc/core/detail/text_format.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/recognition/experiment_report.hpp"
#include "mfpc/recognition/foveation_report.hpp"
#include "mfpc/recognition/recognition_report.hpp"
#include "mfpc/recognition/statistics.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using nlohmann::json;

Pose moved(float x, float y, float z, float turn_deg = 0.0f)
{
    Pose pose = Pose::Identity();
    pose.linear() = Eigen::AngleAxisf(turn_deg * float(M_PI) / 180.0f, Eigen::Vector3f::UnitZ()).toRotationMatrix();
    pose.translation() = Eigen::Vector3f(x, y, z);
    return pose;
}

RecognitionReport two_instances()
{
    RecognitionReport report;
    report.model_file = "carton.pcd";
    report.scene_file = "table.pcd";
    report.mode = FoveationMode::mfpc;
    report.model_centroid = Point(0.0f, 0.0f, 0.1f);
    report.params.scene.keypoint_radius = 0.02f;
    report.params.model.keypoint_radius = 0.5f;  // not what the model was described with:
    report.model_params.keypoint_radius = 0.01f;  // the report says this
    Instance a;
    a.transform = moved(0.1f, 0.0f, 1.0f, 30.0f);
    a.votes = 12.5f;
    a.correspondences.resize(4);
    a.fitness = 0.9f;
    Instance b;
    b.transform = moved(-0.2f, 0.05f, 0.8f);
    b.correspondences.resize(2);
    report.result.instances = {a, b};
    report.result.counts.scene_points = 1000;
    report.result.counts.scene_points_used = 250;
    report.result.counts.correspondences = 6;
    report.result.timings.total = 42.0;
    Evaluation evaluation;
    evaluation.instances_true = 1;
    evaluation.instances_false = 1;
    evaluation.instance_match = {0, -1};
    evaluation.position_error = {0.002f, 0.3f};
    evaluation.rotation_error_deg = {1.5f, 40.0f};
    report.evaluation = evaluation;
    report.ground_truth_file = "table.gt.json";
    report.threads = 3;
    report.warnings = {"a fovea was clamped"};
    return report;
}

TEST(RecognitionReport, JsonSaysWhatTheResultHolds)
{
    const RecognitionReport report = two_instances();
    const json doc = json::parse(to_json(report));
    EXPECT_EQ(doc["model"], "carton.pcd");
    EXPECT_EQ(doc["mode"], "mfpc");
    ASSERT_EQ(doc["instances"].size(), 2u);
    for (std::size_t i = 0; i < 2; ++i) {
        const Point expected = report.result.instances[i].transform * report.model_centroid;
        for (int axis = 0; axis < 3; ++axis)
            EXPECT_FLOAT_EQ(doc["instances"][i]["position"][axis].get<float>(), expected[axis]);
        EXPECT_EQ(doc["instances"][i]["correspondences"], report.result.instances[i].correspondences.size());
        EXPECT_EQ(doc["instances"][i]["transform"].size(), 16u);
        EXPECT_EQ(doc["instances"][i]["ground_truth_instance"], report.evaluation->instance_match[i]);
    }
    EXPECT_EQ(doc["counts"]["scene_points_used"], 250);
    EXPECT_EQ(doc["timings_ms"]["total"], 42.0);
    EXPECT_EQ(doc["threads"], 3);
    // The parameters as used: the scene's from the run, the model's from the model itself.
    EXPECT_FLOAT_EQ(doc["params"]["scene"]["keypoint_radius"].get<float>(), 0.02f);
    EXPECT_FLOAT_EQ(doc["params"]["model"]["keypoint_radius"].get<float>(), 0.01f);
    EXPECT_EQ(doc["evaluation"]["instances_false"], 1);
    EXPECT_FLOAT_EQ(doc["evaluation"]["tolerances"]["instance_m"].get<float>(),
                    report.evaluation_params.instance_translation);
    EXPECT_EQ(doc["warnings"][0], "a fovea was clamped");

    RecognitionReport plain = report;
    plain.evaluation.reset();
    const json unscored = json::parse(to_json(plain));
    EXPECT_FALSE(unscored.contains("evaluation"));
    EXPECT_FALSE(unscored["instances"][0].contains("ground_truth_instance"));
}

TEST(RecognitionReport, TableListsEachInstanceAndItsMatch)
{
    const std::string table = to_table(two_instances());
    EXPECT_NE(table.find("carton.pcd"), std::string::npos);
    EXPECT_NE(table.find("instance 0 (2.0 mm, 1.50 deg)"), std::string::npos) << table;
    EXPECT_NE(table.find("false (300.0 mm, 40.00 deg)"), std::string::npos) << table;
    EXPECT_NE(table.find("evaluation  true 1  false 1"), std::string::npos) << table;
    EXPECT_NE(table.find("total 42.0"), std::string::npos) << table;
}

TEST(RecognitionReport, WrittenPosesReadBack)
{
    const test::TempDir dir;
    dir.write("carton.pcd", "not read: only its presence is checked");
    RecognitionReport report = two_instances();
    const auto result = dir.write("result.json", to_json(report));
    // The model is not in the current directory but beside the result.
    const InstancePoses poses = read_instance_poses(result);
    EXPECT_EQ(poses.model, dir / "carton.pcd");
    ASSERT_EQ(poses.transforms.size(), 2u);
    for (std::size_t i = 0; i < 2; ++i)
        EXPECT_TRUE(poses.transforms[i].isApprox(report.result.instances[i].transform, 1e-6f)) << i;

    report.model_file = "nowhere.pcd";
    EXPECT_THROW(read_instance_poses(dir.write("lost.json", to_json(report))), Error);
    json doc = json::parse(to_json(two_instances()));
    doc["instances"][1]["transform"].erase(0);
    try {
        read_instance_poses(dir.write("short.json", doc.dump()));
        ADD_FAILURE() << "a transform of 15 numbers was read";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("instances[1].transform"), std::string::npos) << error.what();
    }
    doc = json::parse(to_json(two_instances()));
    doc["instances"] = json::array();
    for (std::size_t i = 0; i <= max_instance_poses; ++i) doc["instances"].push_back({{"transform", json::array()}});
    EXPECT_THROW(read_instance_poses(dir.write("many.json", doc.dump())), Error);
}

// Two structures of two levels; the output grouped by region as foveate() writes it.
FoveatedCloud three_regions()
{
    FoveatedCloud foveated;
    const RegionLabel labels[] = {{0, 1}, {0, 1}, {0, 0}, {1, 1}, {1, 1}, {1, 1}};
    for (int i = 0; i < 6; ++i) {
        foveated.cloud.points.push_back(Point(float(i), 0.0f, 1.0f));
        foveated.labels.push_back(labels[i]);
    }
    foveated.cloud.width = 6;
    foveated.regions = {{0, 0, 0.02f, 10, 1}, {0, 1, 0.005f, 4, 2}, {1, 0, 0.02f, 7, 0}, {1, 1, 0.005f, 9, 3}};
    foveated.points_before_downsampling = 30;
    foveated.redundant_points = 5;
    return foveated;
}

TEST(FoveationReport, JsonCountsWhatTheModeKept)
{
    const FoveatedCloud result = three_regions();
    FoveationReport report;
    report.input = "scene.pcd";
    report.structures = 2;
    report.levels = 1;
    report.points_in = 100;
    report.points_finite = 90;
    report.result = &result;
    report.timings_ms = {{"read", 1.0}, {"index", 2.0}, {"total", 4.0}};
    json doc = json::parse(to_json(report));
    EXPECT_EQ(doc["points_out"], 6);
    EXPECT_EQ(doc["points_before_downsampling"], 30);
    EXPECT_EQ(doc["redundant_points_removed"], 5);
    EXPECT_EQ(doc["duplicate_points"], 0);
    EXPECT_EQ(doc["regions"].size(), 4u);
    // Steps in the order they ran.
    EXPECT_LT(to_json(report).find("\"read\""), to_json(report).find("\"index\""));

    report.mode = FoveationMode::raw;
    doc = json::parse(to_json(report));
    EXPECT_EQ(doc["redundant_points_removed"], 0);
    EXPECT_EQ(doc["duplicate_points"], 5);

    report.mode = FoveationMode::single;
    report.single_structure = 1;
    doc = json::parse(to_json(report));
    ASSERT_EQ(doc["regions"].size(), 2u);
    for (const auto& region : doc["regions"]) EXPECT_EQ(region["structure"], 1);
    const std::string table = to_table(report);
    EXPECT_NE(table.find("2 (levels m = 1)"), std::string::npos) << table;
    EXPECT_NE(table.find("total 4.00"), std::string::npos) << table;

    report.result = nullptr;
    EXPECT_THROW(to_json(report), Error);
}

TEST(FoveationReport, RegionCloudsAreTheRunsOfEqualLabels)
{
    const FoveatedCloud foveated = three_regions();
    const std::vector<RegionCloud> regions = region_clouds(foveated);
    ASSERT_EQ(regions.size(), 3u);
    EXPECT_EQ(regions[0].file_name, "structure0_level1.pcd");
    EXPECT_EQ(regions[1].file_name, "structure0_level0.pcd");
    EXPECT_EQ(regions[2].file_name, "structure1_level1.pcd");
    std::size_t total = 0;
    for (const RegionCloud& region : regions) {
        for (const Point& p : region.cloud.points) EXPECT_EQ(foveated.labels[std::size_t(p.x())], region.label);
        total += region.cloud.size();
    }
    EXPECT_EQ(total, foveated.cloud.size());
    FoveatedCloud broken = foveated;
    broken.labels.pop_back();
    EXPECT_THROW(region_clouds(broken), Error);
}

// Strategies A (3 runs: 10, 20, 30 ms) and B (3 runs: 5, 5, 8 ms), B the reference.
ExperimentReport two_strategies()
{
    ExperimentReport report;
    report.config_file = "experiment.json";
    report.config.scene = "dir/table.pcd";
    report.config.runs = 3;
    report.config.reference = 1;
    report.config.strategies.resize(2);
    report.config.strategies[0].name = "A";
    report.config.strategies[1].name = "B";
    report.config.strategies[1].mode = FoveationMode::mfpc;
    for (const auto& [name, times] :
         {std::pair{"A", std::vector<double>{10, 20, 30}}, std::pair{"B", std::vector<double>{5, 5, 8}}}) {
        StrategyOutcome outcome;
        outcome.name = name;
        for (double t : times) {
            RecognitionTimings timings;
            timings.total = t;
            timings.match = t / 2;
            outcome.timings.push_back(timings);
        }
        outcome.counts.scene_points_used = name == std::string("A") ? 1000 : 300;
        outcome.evaluation.instances_true = 2;
        report.outcomes.push_back(outcome);
    }
    report.model_ms = 7.5;
    report.threads = 2;
    return report;
}

TEST(ExperimentReport, EveryFormatSaysTheSameTimes)
{
    const ExperimentReport report = two_strategies();
    const Summary a = summarize(std::vector<double>{10, 20, 30});
    const Summary b = summarize(std::vector<double>{5, 5, 8});
    const double reduction_a = reduction_percent(b.mean, a.mean);

    const json doc = json::parse(to_json(report));
    EXPECT_EQ(doc["reference"], "B");
    ASSERT_EQ(doc["strategies"].size(), 2u);
    EXPECT_DOUBLE_EQ(doc["strategies"][0]["time_ms"]["total"]["mean"].get<double>(), 20.0);
    EXPECT_DOUBLE_EQ(doc["strategies"][0]["time_ms"]["total"]["ci95_high"].get<double>(), a.high);
    EXPECT_DOUBLE_EQ(doc["strategies"][0]["time_ms"]["match"]["median"].get<double>(), 10.0);
    EXPECT_EQ(doc["strategies"][1]["total_ms_per_run"], json::array({5.0, 5.0, 8.0}));
    EXPECT_DOUBLE_EQ(doc["strategies"][0]["time_reduction_vs_reference_percent"].get<double>(), reduction_a);
    EXPECT_DOUBLE_EQ(doc["strategies"][1]["time_reduction_vs_reference_percent"].get<double>(), 0.0);
    EXPECT_EQ(doc["strategies"][1]["mode"], "mfpc");

    const std::string csv = to_csv(report);
    EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 3);
    EXPECT_NE(csv.find("A,none,0,0,0,1000,"), std::string::npos) << csv;
    EXPECT_NE(csv.find(",3,20.000,100.000,"), std::string::npos) << csv;  // runs, mean, variance of A

    const std::string md = to_markdown(report);
    EXPECT_NE(md.find("# Experiment: table.pcd"), std::string::npos) << md;
    EXPECT_NE(md.find("| A | 20.0 | 100.0 | [" + detail::format_fixed(a.low, 1) + ", " + detail::format_fixed(a.high, 1) + "] | " +
                      detail::format_fixed(reduction_a, 1) + "% |"),
              std::string::npos)
        << md;
    EXPECT_NE(md.find("reduction vs B"), std::string::npos) << md;

    const std::string data = to_chart_data(report);
    EXPECT_EQ(std::count(data.begin(), data.end(), '\n'), 3);
    const std::size_t second = data.find('\n') + 1;
    const std::size_t third = data.find('\n', second) + 1;
    EXPECT_EQ(data.compare(second, 9, "\"A\" 1000 "), 0) << data;
    EXPECT_EQ(data.compare(third, 8, "\"B\" 300 "), 0) << data;
}

TEST(ExperimentReport, OneRunHasNoInterval)
{
    ExperimentReport report = two_strategies();
    report.config.runs = 1;
    report.config.reference = -1;
    for (StrategyOutcome& outcome : report.outcomes) outcome.timings.resize(1);
    const json doc = json::parse(to_json(report));
    EXPECT_TRUE(doc["strategies"][0]["time_ms"]["total"]["ci95_low"].is_null());
    EXPECT_TRUE(doc["reference"].is_null());
    EXPECT_TRUE(doc["strategies"][0]["time_reduction_vs_reference_percent"].is_null());
    EXPECT_NE(to_csv(report).find("n/a,n/a"), std::string::npos);
    // The charts draw the mean where there is no interval.
    EXPECT_NE(to_chart_data(report).find(" 10 10 10\n"), std::string::npos) << to_chart_data(report);

    report.outcomes.pop_back();
    EXPECT_THROW(to_json(report), Error);
    EXPECT_THROW(to_markdown(report), Error);
}

}  // namespace
}  // namespace mfpc
