// The demo's report on a run made by hand: its JSON and table say each strategy's counts and
// score; an object that is not built in is refused before anything is written.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mfpc/core/error.hpp"
#include "mfpc/simulation/demo.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

DemoRun three_strategies()
{
    DemoRun run;
    run.params.objects = 2;
    run.params.object = "bottle";
    run.directory = "out/demo";
    run.image = "out/demo/demo.png";
    run.truth.instances.resize(2);
    for (const char* name : {"plain", "auto", "oracle"}) {
        DemoStrategy strategy;
        strategy.name = name;
        const bool foveated = std::string(name) != "plain";
        strategy.result.counts.scene_points_used = foveated ? 900 : 60000;
        strategy.result.counts.scene_keypoints = foveated ? 300 : 4000;
        strategy.result.timings.total = foveated ? 40.0 : 120.0;
        strategy.evaluation.instances_true = foveated ? 2 : 1;
        strategy.evaluation.instances_missed = foveated ? 0 : 1;
        if (foveated) {
            strategy.placement = PlacementResult{};
            strategy.placement->config.structures.resize(strategy.name == "auto" ? 5 : 2);
            strategy.placement->ms = 10.0;
        }
        run.strategies.push_back(strategy);
    }
    run.synthesize_ms = 1000;
    run.recognize_ms = 160;
    run.render_ms = 40;
    return run;
}

TEST(Demo, ReportSaysEachStrategy)
{
    const DemoRun run = three_strategies();
    const auto doc = nlohmann::json::parse(to_json(run));
    EXPECT_EQ(doc["object"], "bottle");
    EXPECT_EQ(doc["instances"], 2);
    EXPECT_EQ(doc["output"], "out/demo");
    ASSERT_EQ(doc["strategies"].size(), 3u);
    EXPECT_EQ(doc["strategies"][0]["strategy"], "plain");
    EXPECT_EQ(doc["strategies"][0]["instances_missed"], 1);
    EXPECT_TRUE(doc["strategies"][0]["placement"].is_null());
    EXPECT_EQ(doc["strategies"][1]["strategy"], "auto");
    EXPECT_EQ(doc["strategies"][1]["scene_points_used"], 900);
    EXPECT_EQ(doc["strategies"][1]["time_ms"], 50.0);  // placement and recognition
    EXPECT_EQ(doc["strategies"][1]["placement"]["structures"], 5);
    EXPECT_EQ(doc["strategies"][2]["strategy"], "oracle");
    EXPECT_EQ(doc["timings_ms"]["synthesize"], 1000.0);

    const std::string table = to_table(run);
    EXPECT_NE(table.find("2 bottles among 3 distractors"), std::string::npos) << table;
    EXPECT_NE(table.find("    1/2 "), std::string::npos) << table;  // plain found 1 of 2
    EXPECT_NE(table.find("    2/2 "), std::string::npos) << table;
    EXPECT_NE(table.find("60,000"), std::string::npos) << table;
    EXPECT_NE(table.find("total 1.2 s"), std::string::npos) << table;
}

TEST(Demo, UnknownObjectWritesNothing)
{
    const test::TempDir dir;
    DemoParams params;
    params.object = "teapot";
    EXPECT_THROW(run_demo(params, dir / "demo"), Error);
    EXPECT_FALSE(std::filesystem::exists(dir / "demo"));
    DemoRun empty;
    EXPECT_THROW(render_demo(empty), Error);
}

}  // namespace
}  // namespace mfpc
