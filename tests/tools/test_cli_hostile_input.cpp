// What an independent fuzzer of the command line found (issue 32), as regression tests: each
// input once crashed, aborted, ran quadratic or left files behind.
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::Result;
using test::line_count;
using test::run;

std::string ascii_pcd(const std::vector<Point>& points, std::uint32_t width, std::uint32_t height)
{
    std::string text = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " +
                       std::to_string(width) + "\nHEIGHT " + std::to_string(height) +
                       "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(points.size()) + "\nDATA ascii\n";
    for (const Point& p : points) {
        char line[96];
        std::snprintf(line, sizeof line, "%.9g %.9g %.9g\n", double(p.x()), double(p.y()), double(p.z()));
        text += line;
    }
    return text;
}

std::string binary_pcd(const std::vector<Point>& points)
{
    std::string text = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " +
                       std::to_string(points.size()) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
                       std::to_string(points.size()) + "\nDATA binary\n";
    const std::size_t start = text.size();
    text.resize(start + points.size() * sizeof(Point));
    std::memcpy(text.data() + start, points.data(), points.size() * sizeof(Point));
    return text;
}

void expect_one_line_error(const std::string& args, const std::string& needle)
{
    const Result r = run(args);
    EXPECT_EQ(r.exit_code, 1) << args << "\n" << r.err;
    EXPECT_EQ(line_count(r.err), 1) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << args << "\n" << r.err;
}

// `info` died of a stack overflow in FLANN's tree build on ±1.7e38, `render --view orbit|top`
// aborted on Embree's ray.valid() from about 1e19: both are beyond the supported range, refused on
// reading with one line.
TEST(CliHostileInput, HugeCoordinatesAreOneLineErrors)
{
    const test::TempDir dir;
    std::vector<Point> points;
    for (int i = 0; i < 50; ++i) points.emplace_back(0.01f * float(i), 0.0f, 1.0f);
    points[20] = Point(1.7e38f, -1.7e38f, 1.0f);
    const auto overflow = dir.write("overflow.pcd", ascii_pcd(points, 50, 1));
    points[20] = Point(1e19f, 0.0f, 1e19f);
    const auto far = dir.write("far.pcd", ascii_pcd(points, 50, 1));
    expect_one_line_error("info '" + overflow.string() + "'", "point 20 has a coordinate beyond");
    for (const char* view : {"orbit:30", "top", "camera"}) {
        expect_one_line_error("render '" + far.string() + "' --view " + view + " -o '" + (dir / "far.png").string() +
                                  "'",
                              "point 20 has a coordinate beyond");
    }
    EXPECT_FALSE(std::filesystem::exists(dir / "far.png"));
}

// Copies of one point (or drivers' zeros for missing depth) made the neighbour searches of info,
// render and recognize quadratic: 40,000 copies took info 3.9 s and render 4.4 s, the shared scene
// with its invalid pixels as zeros took render 43 s. Now each position is searched once; a
// quadratic path would take minutes here.
TEST(CliHostileInput, CopiesOfOnePointCostWhatOnePointCosts)
{
    const test::TempDir dir;
    std::vector<Point> points(200000, Point(0.1f, 0.2f, 1.0f));
    for (int i = 0; i < 2000; ++i) points.emplace_back(0.002f * float(i % 40), 0.002f * float(i / 40), 1.0f);
    const auto copies = dir.write("copies.pcd", binary_pcd(points));

    const Result info = run("--json - -q info '" + copies.string() + "'");
    ASSERT_EQ(info.exit_code, 0) << info.err;
    const auto json = nlohmann::json::parse(info.out);
    EXPECT_EQ(json["points_finite"], points.size());
    // The copies are at distance 0; the grid's points 2 mm from each other (one of them from a copy).
    EXPECT_LT(json["mean_spacing"].get<double>(), 0.002 * 2000.0 / double(points.size()) + 1e-9);

    const Result render = run("-q render '" + copies.string() + "' -o '" + (dir / "copies.png").string() + "'");
    EXPECT_EQ(render.exit_code, 0) << render.err;
    const Result recognize = run("-q recognize --model '" + copies.string() + "' --scene '" + copies.string() +
                                 "' -p '" MFPC_SOURCE_DIR "/examples/params/pcl_tutorial.json'");
    // Whatever it finds in itself, it finishes; the copies add nothing to describe.
    EXPECT_NE(recognize.exit_code, 2) << recognize.err;
    EXPECT_LE(line_count(recognize.err), 1) << recognize.err;
}

// An organized cloud whose missing depth is written as (0, 0, 0): invalid pixels, as NaN is.
TEST(CliHostileInput, OrganizedZerosAreMissingDepth)
{
    const test::TempDir dir;
    std::vector<Point> grid;
    for (int row = 0; row < 20; ++row)
        for (int column = 0; column < 30; ++column)
            grid.push_back(column < 10 ? Point::Zero().eval()
                                       : Point(0.002f * float(column), 0.002f * float(row), 1.0f));
    const auto path = dir.write("zeros.pcd", ascii_pcd(grid, 30, 20));
    const Result info = run("--json - -q info '" + path.string() + "'");
    ASSERT_EQ(info.exit_code, 0) << info.err;
    const auto json = nlohmann::json::parse(info.out);
    EXPECT_EQ(json["points"], 600);
    EXPECT_EQ(json["points_finite"], 400);
    EXPECT_EQ(json["points_zero"], 200);
    EXPECT_NEAR(json["bounding_box"]["min"][0].get<double>(), 0.02, 1e-6);
}

// foveate -o with --regions-dir wrote the foveated cloud, then failed on a region: now both are
// written or neither, and a directory made for the regions goes with a failure.
TEST(CliHostileInput, FoveateOutputsAreAllOrNone)
{
    const test::TempDir dir;
    const auto out = dir / "out.pcd";
    const auto regions = dir / "regions";
    std::filesystem::create_directories(regions / "structure0_level1.pcd");  // a region's name, taken
    const Result failed = run("-q foveate --procedural -o '" + out.string() + "' --regions-dir '" + regions.string() + "'");
    EXPECT_EQ(failed.exit_code, 1) << failed.err;
    EXPECT_EQ(line_count(failed.err), 1) << failed.err;
    EXPECT_FALSE(std::filesystem::exists(out));
    std::vector<std::string> left;
    for (const auto& entry : std::filesystem::directory_iterator(regions)) left.push_back(entry.path().filename());
    EXPECT_EQ(left, std::vector<std::string>{"structure0_level1.pcd"});

    const auto fresh = dir / "fresh" / "regions";
    std::filesystem::create_directories(dir / "fresh");
    const Result bad_output = run("-q foveate --procedural -o '" + (dir / "out.xyz").string() + "' --regions-dir '" +
                                  fresh.string() + "'");
    EXPECT_EQ(bad_output.exit_code, 1) << bad_output.err;
    EXPECT_FALSE(std::filesystem::exists(fresh));

    std::filesystem::remove(regions / "structure0_level1.pcd");
    const Result ok = run("-q foveate --procedural -o '" + out.string() + "' --regions-dir '" + regions.string() + "'");
    EXPECT_EQ(ok.exit_code, 0) << ok.err;
    EXPECT_TRUE(std::filesystem::exists(out));
    EXPECT_TRUE(std::filesystem::exists(regions / "structure0_level1.pcd"));
}

// synth wrote the scan, then failed on the labels and left a scene without its ground truth: a
// scene's files are now all written or none.
TEST(CliHostileInput, SynthSceneFilesAreAllOrNone)
{
    const test::TempDir dir;
    std::filesystem::create_directories(dir / "scene" / "labels.png" / "taken");
    const Result failed = run("-q synth -o '" + (dir / "scene").string() + "'");
    EXPECT_EQ(failed.exit_code, 1) << failed.err;
    EXPECT_EQ(line_count(failed.err), 1) << failed.err;
    // The models are a set of their own, written before; none of the scene's files is there.
    for (const char* name : {"scene.pcd", "scene.json", "scene.gt.json", "fovea.json", "fovea_all.json"})
        EXPECT_FALSE(std::filesystem::exists(dir / "scene" / name)) << name;
    EXPECT_TRUE(std::filesystem::is_directory(dir / "scene" / "labels.png" / "taken"));
}

}  // namespace
}  // namespace mfpc
