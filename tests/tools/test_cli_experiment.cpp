// `mfpc experiment` as a user meets it: every report file from one command, numbers that agree
// between the files, and one-line errors.
#include <algorithm>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "mfpc/core/detail/text_format.hpp"
#include "mfpc/rendering/png_image.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::expect_one_line_error;
using test::quoted;
using test::Result;
using test::run;
using test::slurp;
using detail::format_fixed;

TEST(CliExperiment, WritesEveryReportFile)
{
    MFPC_SHARED_FILE_OR_SKIP(scene, "milk_pair.pcd");
    const test::TempDir dir;
    const std::string data = test::shared_data_dir().string();
    const std::string configs = std::string(MFPC_SOURCE_DIR) + "/examples/configs/";
    const auto config = dir.write("experiment.json", "{\"model\": \"" + data + "/milk.pcd\", \"scene\": \"" + data +
                                                         "/milk_pair.pcd\", \"ground_truth\": \"" + data +
                                                         "/milk_pair.gt.json\", \"runs\": 2, \"strategies\": ["
                                                         "{\"name\": \"non-foveated\", \"mode\": \"none\"},"
                                                         "{\"name\": \"raw\", \"mode\": \"raw\", \"fovea\": \"" +
                                                         configs + "milk_pair_two.json\"},"
                                                         "{\"name\": \"MFPC\", \"mode\": \"mfpc\", \"fovea\": \"" +
                                                         configs + "milk_pair_two.json\"},"
                                                         "{\"name\": \"auto\", \"mode\": \"mfpc\", \"fovea\": \"auto\"}]}");
    // A quote in the output folder's name once ended a string in the shell command that ran
    // gnuplot (and in its script): names reach neither now.
    const std::filesystem::path out = dir / "it's a report";
    const Result r = run("experiment --config " + quoted(config) + " -o \"" + out.string() + "\"");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    for (const char* file : {"report.json", "report.csv", "report.md", "strategy_1.png", "strategy_3.png",
                             "fig11a_points.png", "fig11d_correct_correspondences.png", "fig12a_precision.png",
                             "fig12d_time.png"})
        EXPECT_TRUE(std::filesystem::exists(out / file)) << file;

    const auto report = nlohmann::json::parse(slurp(out / "report.json"));
    ASSERT_EQ(report["strategies"].size(), 4u);
    EXPECT_EQ(report["reference"], "MFPC");
    // The placed strategy: its structures, its placement a stage of every run, its time in the total.
    const auto& placed = report["strategies"][3];
    EXPECT_EQ(placed["fovea"], "auto");
    EXPECT_EQ(placed["placement"]["strategy"], "segments");
    EXPECT_GT(placed["placement"]["structures"].get<int>(), 0);
    EXPECT_GT(placed["time_ms"]["place"]["mean"].get<double>(), 0.0);
    EXPECT_TRUE(report["strategies"][2]["placement"].is_null());
    EXPECT_EQ(report["strategies"][2]["time_ms"]["place"]["mean"].get<double>(), 0.0);
    for (const auto& strategy : report["strategies"]) {
        EXPECT_EQ(strategy["total_ms_per_run"].size(), 2u);
        const auto runs = strategy["total_ms_per_run"];
        // The mean reported is the mean of the runs measured.
        EXPECT_NEAR(strategy["time_ms"]["total"]["mean"].get<double>(),
                    (runs[0].get<double>() + runs[1].get<double>()) / 2.0, 1e-9);
    }
    const auto& raw = report["strategies"][1]["counts"];
    const auto& mfpc = report["strategies"][2]["counts"];
    EXPECT_EQ(mfpc["points_before_downsampling"].get<long>(),
              raw["points_before_downsampling"].get<long>() - raw["redundant_points"].get<long>());
    // The three reports say the same numbers.
    const std::string csv = slurp(out / "report.csv");
    const std::string md = slurp(out / "report.md");
    for (const auto& strategy : report["strategies"]) {
        const double mean = strategy["time_ms"]["total"]["mean"].get<double>();
        const std::string name = strategy["name"].get<std::string>();
        const std::size_t row = csv.find("\n" + name + ",");
        ASSERT_NE(row, std::string::npos) << name;
        const std::string line = csv.substr(row + 1, csv.find('\n', row + 1) - row - 1);
        EXPECT_NE(line.find("," + std::to_string(strategy["evaluation"]["instances_true"].get<int>()) + ","),
                  std::string::npos) << line;
        EXPECT_NE(line.find("," + format_fixed(mean, 3) + ","), std::string::npos) << line << " mean " << mean;
        EXPECT_NE(md.find("| " + name + " | " + format_fixed(mean, 1) + " |"), std::string::npos) << name;
    }
    // Each strategy's picture is the sensor's view (the scene's size) of what it kept: the whole
    // scene in its colours, the foveated ones coloured by region and unlike it.
    const RgbImage whole = read_png_rgb(out / "strategy_1.png");
    const RgbImage raw_picture = read_png_rgb(out / "strategy_2.png");
    const RgbImage foveated = read_png_rgb(out / "strategy_3.png");
    for (const RgbImage* image : {&whole, &raw_picture, &foveated}) {
        EXPECT_EQ(image->width, 640u);
        EXPECT_EQ(image->height, 480u);
    }
    EXPECT_NE(foveated.pixels, whole.pixels);
    EXPECT_NE(raw_picture.pixels, whole.pixels);
    EXPECT_GT(std::count(r.out.begin(), r.out.end(), '\n'), 10);  // the tables on stdout
}

TEST(CliExperiment, BadConfigIsOneLine)
{
    const test::TempDir dir;
    expect_one_line_error(run("experiment -o " + quoted(dir / "r")), 2, "no config");
    expect_one_line_error(run("experiment --config " + quoted(dir / "missing.json") + " -o " + quoted(dir / "r")), 1,
                          "missing config");
    expect_one_line_error(run("experiment --config " + quoted(dir.write("bad.json", "{\"model\": 1}")) + " -o " +
                              quoted(dir / "r")),
                          1, "bad config");
    expect_one_line_error(run("experiment --runs 0 --config x.json -o " + quoted(dir / "r")), 2, "zero runs");
    expect_one_line_error(run("experiment --config " +
                              quoted(dir.write("pipe.json", "{\"model\": \"m.pcd\", \"scene\": \"s.pcd\", "
                                                            "\"ground_truth\": \"g.json\", \"strategies\": "
                                                            "[{\"name\": \"a|b\", \"mode\": \"none\"}]}")) +
                              " -o " + quoted(dir / "r")),
                          1, "a '|' in a strategy name");
}

}  // namespace
}  // namespace mfpc
