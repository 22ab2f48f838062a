// `mfpc render` as a user meets it: usage errors, one-line input errors, and a PNG of the right
// size with the instances of a result drawn in red.
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/rendering/png_image.hpp"
#include "mfpc/simulation/primitive_scene.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::expect_one_line_error;
using test::line_count;
using test::quoted;
using test::Result;
using test::run;
using test::slurp;

const std::string identity = "[1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]";

// A procedural scene on disk: the organized cloud, its fovea config, and a "model" that is the
// scene's points of the first object (so the identity transform puts it back in place).
struct SceneFiles {
    test::TempDir dir;
    std::filesystem::path cloud, fovea, model;
    PrimitiveScene scene = make_primitive_scene();
    SceneFiles()
    {
        cloud = dir / "scene.pcd";
        write_cloud(cloud, scene.cloud, {CloudEncoding::binary, true});
        fovea = dir.write("fovea.json", to_json(scene.fovea));
        std::vector<std::uint32_t> object;
        for (std::uint32_t i = 0; i < scene.cloud.size(); ++i) {
            if (scene.objects[0].bounds.contains(scene.cloud.points[i])) object.push_back(i);
        }
        model = dir / "model.pcd";
        write_cloud(model, select(scene.cloud, object));
    }
};

TEST(CliRender, UsageErrorsExitTwo)
{
    for (const char* args : {"render", "render x.pcd", "render -o out.png", "render x.pcd -o out.jpg",
                             "render x.pcd -o out", "render x.pcd --view sideways -o out.png",
                             "render x.pcd --view orbit:left -o out.png", "render x.pcd --size 640 -o out.png",
                             "render x.pcd --size 0x480 -o out.png", "render x.pcd --point-radius -1 -o out.png",
                             "render x.pcd --bogus -o out.png"}) {
        expect_one_line_error(run(args), 2, args);
    }
    EXPECT_NE(run("render x.pcd --view sideways -o out.png").err.find("sideways"), std::string::npos);
}

TEST(CliRender, HelpNamesEveryOption)
{
    const Result help = run("render --help");
    EXPECT_EQ(help.exit_code, 0);
    for (const char* option : {"CLOUD", "--fovea", "--result", "--view", "--size", "--point-radius", "--output"}) {
        EXPECT_NE(help.out.find(option), std::string::npos) << option;
    }
}

TEST(CliRender, BadInputIsOneLineAndExitOne)
{
    const SceneFiles files;
    const test::TempDir& dir = files.dir;
    const std::string out = " -o " + quoted(dir / "out.png");
    const auto not_json = dir.write("broken.json", "{\"model\": ");
    const auto no_model = dir.write("no_model.json", "{\"instances\": []}");
    const auto missing_model = dir.write("missing_model.json", R"({"model": "nowhere.pcd", "instances": []})");
    const auto short_transform = dir.write(
        "short.json", R"({"model": "model.pcd", "instances": [{"transform": [1, 0, 0, 0, 0, 1, 0, 0]}]})");
    const auto not_rigid = dir.write(
        "shear.json", R"({"model": "model.pcd", "instances": [{"transform": [1,0.5,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]})");
    const auto bad_fovea = dir.write("fovea_bad.json", R"({"levels": 3, "structures": []})");
    const auto garbage_cloud = dir.write("garbage.pcd", "not a cloud");

    expect_one_line_error(run("render " + quoted(dir / "missing.pcd") + out), 1, "missing cloud");
    expect_one_line_error(run("render " + quoted(garbage_cloud) + out), 1, "garbage cloud");
    for (const auto& result : {not_json, no_model, missing_model, short_transform, not_rigid}) {
        const Result r = run("render " + quoted(files.cloud) + " --result " + quoted(result) + out);
        expect_one_line_error(r, 1, result.string());
        EXPECT_NE(r.err.find(result.filename().string()), std::string::npos) << r.err;
    }
    expect_one_line_error(run("render " + quoted(files.cloud) + " --fovea " + quoted(bad_fovea) + out), 1, "fovea");
    expect_one_line_error(run("render " + quoted(files.cloud) + " --result " + quoted(dir / "none.json") + out), 1,
                          "missing result");
    expect_one_line_error(run("render " + quoted(files.cloud) + " -o " + quoted(dir / "no_dir" / "a.png")), 1,
                          "missing output directory");
    EXPECT_FALSE(std::filesystem::exists(dir / "out.png"));
}

// The result file is read before the cloud, so these need no cloud on disk.
TEST(CliRender, ResultWithDuplicateKeysDeepNestingOrTooManyInstancesIsRefused)
{
    const test::TempDir dir;
    const auto render = [&](const std::filesystem::path& result) {
        return run("render " + quoted(dir / "scene.pcd") + " --result " + quoted(result) + " -o " +
                   quoted(dir / "out.png"));
    };
    const std::string instance = "{\"transform\": " + identity + "}";

    const auto twice = dir.write("twice.json", "{\"model\": \"m.pcd\", \"instances\": [" + instance +
                                                   ", {\"transform\": [], \"transform\": []}]}");
    Result r = render(twice);
    expect_one_line_error(r, 1, "duplicate key");
    EXPECT_EQ(r.err, "mfpc: " + twice.string() + ": instances[1].transform: duplicate key\n");

    const auto deep = dir.write("deep.json", "{\"model\": \"m.pcd\", \"instances\": " + std::string(100, '[') +
                                                 std::string(100, ']') + "}");
    r = render(deep);
    expect_one_line_error(r, 1, "deep nesting");
    EXPECT_EQ(r.err, "mfpc: " + deep.string() + ": invalid JSON: nested deeper than 64 levels\n");

    // 1001 instances: refused before the model is even looked for (m.pcd does not exist).
    std::string instances = instance;
    for (int i = 1; i < 1001; ++i) instances += ", " + instance;
    const auto many = dir.write("many.json", "{\"model\": \"m.pcd\", \"instances\": [" + instances + "]}");
    r = render(many);
    expect_one_line_error(r, 1, "too many instances");
    EXPECT_EQ(r.err, "mfpc: " + many.string() + ": instances: holds 1001 instances; at most 1000 can be drawn\n");
}

TEST(CliRender, WritesAPngOfTheExpectedSizeWithInstancesInRed)
{
    const SceneFiles files;
    const test::TempDir& dir = files.dir;
    // The model path is relative to the result's folder, as for a result moved with its model.
    const auto result = dir.write("result.json", R"({"model": "model.pcd", "instances": [{"transform": )" + identity +
                                                     "}]}");
    const auto image_path = dir / "scene.png";
    const auto json_path = dir / "summary.json";
    const Result r = run("--json " + quoted(json_path) + " render " + quoted(files.cloud) + " --fovea " +
                         quoted(files.fovea) + " --result " + quoted(result) + " -o " + quoted(image_path));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
    const RgbImage image = read_png_rgb(image_path);
    EXPECT_EQ(image.width, 640u);
    EXPECT_EQ(image.height, 480u);
    std::size_t red = 0;
    for (std::size_t i = 0; i < image.pixels.size(); i += 3) {
        red += image.pixels[i] == 220 && image.pixels[i + 1] == 30 && image.pixels[i + 2] == 30;
    }
    EXPECT_GT(red, 100u);

    const auto summary = nlohmann::json::parse(slurp(json_path));
    EXPECT_EQ(summary["output"], image_path.string());
    EXPECT_EQ(summary["width"], 640);
    EXPECT_EQ(summary["height"], 480);
    EXPECT_EQ(summary["points"], files.scene.cloud.size());
    EXPECT_EQ(summary["boxes"], files.scene.fovea.structures.size() * std::size_t(files.scene.fovea.levels() + 1));
    EXPECT_EQ(summary["instances"], 1);
    EXPECT_GT(summary["overlay_points"].get<std::size_t>(), 0u);
    EXPECT_EQ(summary["view"], "camera");

    // Another size and view; the table goes to stdout.
    const auto small = dir / "top.png";
    const Result top = run("render " + quoted(files.cloud) + " --view top --size 320x200 -o " + quoted(small));
    ASSERT_EQ(top.exit_code, 0) << top.err;
    EXPECT_NE(top.out.find("320x200"), std::string::npos) << top.out;
    const RgbImage small_image = read_png_rgb(small);
    EXPECT_EQ(small_image.width, 320u);
    EXPECT_EQ(small_image.height, 200u);
}

TEST(CliRender, RealSceneWithItsGroundTruth)
{
    MFPC_SHARED_FILE_OR_SKIP(scene, "milk_pair.pcd");
    MFPC_SHARED_FILE_OR_SKIP(truth, "milk_pair.gt.json");
    const test::TempDir dir;
    const auto fovea = std::filesystem::path(MFPC_SOURCE_DIR) / "examples/configs/milk_pair_two.json";
    const auto image_path = dir / "milk_pair.png";
    // The ground truth names its model ("milk.pcd") relative to its own folder.
    const Result r = run("-q render " + quoted(scene) + " --fovea " + quoted(fovea) + " --result " + quoted(truth) +
                         " -o " + quoted(image_path));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const RgbImage image = read_png_rgb(image_path);
    ASSERT_EQ(image.width, 640u);
    // Around both cartons' centres (from examples/configs/README.md) the picture is mostly red; box
    // edges in front of the cartons take a few pixels.
    for (const auto& [x, y, z] : {std::array<float, 3>{-0.063f, -0.138f, 0.8025f}, {0.046f, 0.020f, 0.568f}}) {
        const int u0 = int(std::lround(319.5f + 525.0f * x / z));
        const int v0 = int(std::lround(239.5f + 525.0f * y / z));
        int red = 0;
        for (int v = v0 - 5; v <= v0 + 5; ++v) {
            for (int u = u0 - 5; u <= u0 + 5; ++u) {
                const std::uint8_t* p = image.pixels.data() + (std::size_t(v) * 640 + std::size_t(u)) * 3;
                red += p[0] == 220 && p[1] == 30 && p[2] == 30;
            }
        }
        EXPECT_GT(red, 121 * 3 / 4) << u0 << " " << v0;
    }
}

}  // namespace
}  // namespace mfpc
