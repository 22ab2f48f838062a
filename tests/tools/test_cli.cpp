// The mfpc command line as a user meets it: exit codes, one-line errors, and the numbers it prints.
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mfpc/core/cloud_io.hpp"
#include "cli_runner.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::Result;
using test::line_count;
using test::run;
using test::slurp;

TEST(Cli, HelpAndVersion)
{
    const Result help = run("--help");
    EXPECT_EQ(help.exit_code, 0);
    EXPECT_NE(help.out.find("foveate"), std::string::npos);
    EXPECT_NE(help.out.find("info"), std::string::npos);
    const Result version = run("--version");
    EXPECT_EQ(version.exit_code, 0);
    EXPECT_NE(version.out.find("mfpc 0."), std::string::npos);
    for (const char* command : {"info", "foveate"}) {
        const Result sub = run(std::string(command) + " --help");
        EXPECT_EQ(sub.exit_code, 0) << command;
        EXPECT_NE(sub.out.find("Usage"), std::string::npos) << command;
    }
}

TEST(Cli, UsageErrorsExitTwo)
{
    for (const char* args : {"", "frobnicate", "info", "--threads 0 info x.pcd", "info --bogus x.pcd",
                             "foveate", "foveate --procedural in.pcd", "foveate --procedural --mode sideways",
                             "foveate --procedural --structure 1", "foveate --procedural --mode single",
                             "foveate --procedural --mode single --structure 9",
                             // An empty value, as an unset shell variable gives, is not "not given".
                             "foveate --procedural -o ''", "--json '' foveate --procedural", "info ''",
                             "recognize --model m.pcd --scene s.pcd --strict"}) {
        const Result r = run(args);
        EXPECT_EQ(r.exit_code, 2) << "mfpc " << args << "\n" << r.err;
        EXPECT_EQ(r.err.rfind("mfpc: ", 0), 0u) << "mfpc " << args << "\n" << r.err;
        EXPECT_EQ(line_count(r.err), 1) << "mfpc " << args << "\n" << r.err;
    }
}

TEST(Cli, InputErrorsAreOneLineAndExitOne)
{
    const test::TempDir dir;
    const auto truncated = dir.write("truncated.pcd",
                                     "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                     "WIDTH 10\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 10\nDATA binary\nabc");
    const auto bad_config = dir.write("bad.json", R"({"levels": 3, "structures": [{"outer_min": [0, 0]}]})");
    const auto cloud = dir.write("ok.pcd", "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                           "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n"
                                           "0 0 1\n0.1 0 1\n");
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"info '" + (dir / "missing.pcd").string() + "'", "missing.pcd"},
        {"info '" + truncated.string() + "'", "truncated.pcd"},
        {"info '" + dir.path().string() + "'", dir.path().filename().string()},
        {"foveate '" + cloud.string() + "' --config '" + bad_config.string() + "'", "outer_min"},
        {"foveate '" + cloud.string() + "' --config '" + (dir / "nope.json").string() + "'", "nope.json"},
        {"foveate --procedural -o '" + (dir / "no/such/dir/out.pcd").string() + "'", "out.pcd"},
        {"foveate --procedural -o '" + (dir / "out.xyz").string() + "'", "out.xyz"},
        {"foveate --procedural --encoding binary_compressed -o '" + (dir / "out.ply").string() + "'", "binary_compressed"},
    };
    for (const auto& [args, needle] : cases) {
        const Result r = run(args);
        EXPECT_EQ(r.exit_code, 1) << args << "\n" << r.err;
        EXPECT_EQ(line_count(r.err), 1) << args << "\n" << r.err;
        EXPECT_EQ(r.err.rfind("mfpc: ", 0), 0u) << r.err;
        EXPECT_NE(r.err.find(needle), std::string::npos) << args << "\n" << r.err;
    }
    EXPECT_FALSE(std::filesystem::exists(dir / "no"));
}

TEST(Cli, InfoOnTheSharedScene)
{
    MFPC_SHARED_FILE_OR_SKIP(scene, "milk_cartoon_all_small_clorox.pcd");
    const Result r = run("--json - info '" + scene.string() + "'");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto json = nlohmann::json::parse(r.out);
    EXPECT_EQ(json["points"], 307200);
    EXPECT_EQ(json["points_finite"], 241407);
    EXPECT_EQ(json["width"], 640);
    EXPECT_EQ(json["height"], 480);
    EXPECT_GT(json["mean_spacing"].get<double>(), 0.0005);
    EXPECT_LT(json["mean_spacing"].get<double>(), 0.01);

    const Result table = run("info '" + scene.string() + "'");
    EXPECT_EQ(table.exit_code, 0);
    EXPECT_NE(table.out.find("307,200"), std::string::npos);
    EXPECT_NE(table.out.find("241,407"), std::string::npos);
    EXPECT_NE(table.out.find("640 x 480"), std::string::npos);
}

// A spacing needs two points: with fewer there is none to report (not 0 mm).
TEST(Cli, InfoOfASinglePointHasNoSpacing)
{
    const test::TempDir dir;
    const auto one = dir.write("one.pcd", "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                          "WIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n1 2 3\n");
    const Result r = run("--json - info '" + one.string() + "'");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(nlohmann::json::parse(r.out)["mean_spacing"].is_null());
    const Result table = run("info '" + one.string() + "'");
    EXPECT_NE(table.out.find("n/a (fewer than 2 finite points)"), std::string::npos) << table.out;
}

nlohmann::json foveate_json(const std::string& args)
{
    const Result r = run("--json - foveate " + args);
    EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.err;
    return nlohmann::json::parse(r.out);
}

TEST(Cli, FoveateProceduralSceneIdentities)
{
    const auto treated = foveate_json("--procedural --mode mfpc");
    const auto raw = foveate_json("--procedural --mode raw");
    const auto none = foveate_json("--procedural --mode none");
    std::size_t singles = 0;
    for (int s = 0; s < int(treated["structures"]); ++s) {
        singles += foveate_json("--procedural --mode single --structure " + std::to_string(s))["points_before_downsampling"]
                       .get<std::size_t>();
    }
    EXPECT_EQ(raw["points_before_downsampling"].get<std::size_t>(), singles);
    EXPECT_EQ(treated["redundant_points_removed"].get<std::size_t>(),
              raw["points_before_downsampling"].get<std::size_t>() -
                  treated["points_before_downsampling"].get<std::size_t>());
    EXPECT_GT(treated["redundant_points_removed"].get<std::size_t>(), 0u);
    EXPECT_LT(treated["points_out"].get<std::size_t>(), treated["points_before_downsampling"].get<std::size_t>());
    EXPECT_EQ(none["points_out"], none["points_finite"]);
    std::size_t after = 0;
    for (const auto& region : treated["regions"]) {
        after += region["points_after"].get<std::size_t>();
        EXPECT_LE(region["points_after"].get<std::size_t>(), region["points_before"].get<std::size_t>());
    }
    EXPECT_EQ(after, treated["points_out"].get<std::size_t>());
    for (const char* key : {"index", "label", "downsample", "total"}) {
        EXPECT_TRUE(treated["timings_ms"].contains(key)) << key;
    }
}

TEST(Cli, FoveateOutputIsBitIdenticalAcrossThreadCounts)
{
    const test::TempDir dir;
    for (const char* threads : {"1", "2"}) {
        const Result r = run(std::string("--threads ") + threads + " -q foveate --procedural -o '" +
                             (dir / (std::string("out") + threads + ".pcd")).string() + "' --regions-dir '" +
                             (dir / (std::string("regions") + threads)).string() + "'");
        ASSERT_EQ(r.exit_code, 0) << r.err;
        EXPECT_TRUE(r.out.empty());
    }
    EXPECT_EQ(slurp(dir / "out1.pcd"), slurp(dir / "out2.pcd"));
    const PointCloud cloud = read_cloud(dir / "out1.pcd");
    EXPECT_GT(cloud.size(), 1000u);
    std::size_t region_points = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir / "regions1")) {
        region_points += read_cloud(entry.path()).size();
        EXPECT_EQ(slurp(entry.path()), slurp(dir / "regions2" / entry.path().filename()));
    }
    EXPECT_EQ(region_points, cloud.size());
}

TEST(Cli, FoveateSharedSceneWithShippedConfig)
{
    MFPC_SHARED_FILE_OR_SKIP(scene, "milk_pair.pcd");
    const auto config = std::filesystem::path(MFPC_SOURCE_DIR) / "examples/configs/milk_pair_two.json";
    const auto treated = foveate_json("'" + scene.string() + "' --config '" + config.string() + "'");
    const auto raw = foveate_json("'" + scene.string() + "' --config '" + config.string() + "' --mode raw");
    EXPECT_EQ(treated["points_in"], 307200);
    EXPECT_EQ(treated["redundant_points_removed"].get<std::size_t>(),
              raw["points_before_downsampling"].get<std::size_t>() -
                  treated["points_before_downsampling"].get<std::size_t>());
    const Result single = run("foveate '" + scene.string() + "' --config '" + config.string() + "' --mode single");
    EXPECT_EQ(single.exit_code, 2);
    EXPECT_NE(single.err.find("--structure"), std::string::npos);
}

}  // namespace
}  // namespace mfpc
