// `mfpc model` and `mfpc recognize` as a user meets them: the model cache, the result JSON, and
// one-line errors for bad input.
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::expect_one_line_error;
using test::line_count;
using test::quoted;
using test::Result;
using test::run;
using test::slurp;

TEST(CliRecognize, UsageErrorsExitTwo)
{
    for (const char* args : {"recognize", "recognize --model m.pcd", "recognize --scene s.pcd",
                             "recognize --model m.pcd --scene s.pcd --mode mfpc",
                             "recognize --model m.pcd --scene s.pcd --mode sideways", "model", "model m.pcd",
                             "model m.pcd -o m.bin"}) {
        expect_one_line_error(run(args), 2, args);
    }
}

TEST(CliRecognize, BadInputIsOneLineAndExitOne)
{
    MFPC_SHARED_FILE_OR_SKIP(model, "milk.pcd");
    const test::TempDir dir;
    const auto garbage = dir.write("garbage.mfpcm", "this is not a model cache");
    const auto bad_params = dir.write("params.json", R"({"scene": {"shot_radius": -1}})");
    const auto unknown_key = dir.write("unknown.json", R"({"hough_bins": 0.01})");
    const auto not_json = dir.write("broken.json", "{");
    const auto empty = dir.write("empty.pcd", "");
    expect_one_line_error(run("recognize --model " + quoted(garbage) + " --scene " + quoted(model)), 1, "garbage cache");
    expect_one_line_error(run("recognize --model " + quoted(dir / "missing.pcd") + " --scene " + quoted(model)), 1,
                          "missing model");
    expect_one_line_error(run("recognize --model " + quoted(model) + " --scene " + quoted(empty)), 1, "empty scene");
    for (const auto& params : {bad_params, unknown_key, not_json}) {
        const Result r = run("recognize --model " + quoted(model) + " --scene " + quoted(model) + " --params " +
                             quoted(params));
        expect_one_line_error(r, 1, params.string());
    }
    const Result r = run("recognize --model " + quoted(model) + " --scene " + quoted(model) + " --params " +
                         quoted(unknown_key));
    EXPECT_NE(r.err.find("hough_bins"), std::string::npos) << r.err;
}

// A model that gives fewer than 3 keypoints is refused with the likely cause: an object small for
// the keypoint radius (few sampled), or supports with no frame (many sampled, none valid).
TEST(CliRecognize, AModelWithoutKeypointsSaysWhy)
{
    const test::TempDir dir;
    std::string tiny = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
                       "POINTS 2\nDATA ascii\n0 0 1\n0.001 0 1\n";
    std::string line = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 500\nHEIGHT 1\n"
                       "POINTS 500\nDATA ascii\n";
    for (int i = 0; i < 500; ++i) line += std::to_string(0.001 * i) + " 0 1\n";
    Result r = run("model " + quoted(dir.write("tiny.pcd", tiny)) + " -o " + quoted(dir / "t.mfpcm"));
    expect_one_line_error(r, 1, "tiny");
    EXPECT_NE(r.err.find("is it too small for keypoint_radius 0.01?"), std::string::npos) << r.err;
    r = run("model " + quoted(dir.write("line.pcd", line)) + " -o " + quoted(dir / "l.mfpcm"));
    expect_one_line_error(r, 1, "line");
    EXPECT_NE(r.err.find("50 of its 50 keypoints have no defined local reference frame"), std::string::npos) << r.err;
}

// The model cache: written once, read instead of the cloud with the same result; a cache damaged
// on disk is refused, not trusted.
TEST(CliRecognize, ModelCacheGivesTheSameResultAndRejectsDamage)
{
    MFPC_SHARED_FILE_OR_SKIP(model, "milk.pcd");
    MFPC_SHARED_FILE_OR_SKIP(scene, "milk_pair.pcd");
    MFPC_SHARED_FILE_OR_SKIP(truth, "milk_pair.gt.json");
    const test::TempDir dir;
    const auto cache = dir / "milk.mfpcm";
    const Result made = run("-q model " + quoted(model) + " -o " + quoted(cache));
    ASSERT_EQ(made.exit_code, 0) << made.err;

    const auto fovea = std::filesystem::path(MFPC_SOURCE_DIR) / "examples/configs/milk_pair_two.json";
    const std::string rest = " --scene " + quoted(scene) + " --ground-truth " + quoted(truth) + " --fovea " + quoted(fovea);
    const Result from_cloud = run("--json " + quoted(dir / "a.json") + " recognize --model " + quoted(model) + rest);
    const Result from_cache = run("--json " + quoted(dir / "b.json") + " recognize --model " + quoted(cache) + rest);
    ASSERT_EQ(from_cloud.exit_code, 0) << from_cloud.err;
    ASSERT_EQ(from_cache.exit_code, 0) << from_cache.err;
    const auto a = nlohmann::json::parse(slurp(dir / "a.json"));
    const auto b = nlohmann::json::parse(slurp(dir / "b.json"));
    EXPECT_EQ(a["instances"], b["instances"]);
    EXPECT_EQ(a["evaluation"]["instances_true"], 2);
    EXPECT_EQ(a["evaluation"]["instances_false"], 0);
    EXPECT_TRUE(b["model_timings_ms"]["cached"].get<bool>());
    for (const char* key : {"scene_points", "scene_points_used", "scene_keypoints", "model_keypoints", "correspondences"})
        EXPECT_TRUE(a["counts"].contains(key)) << key;
    for (const char* key : {"foveate", "normals", "keypoints", "lrf", "descriptors", "match", "group", "verify", "total"})
        EXPECT_TRUE(a["timings_ms"].contains(key)) << key;
    ASSERT_EQ(a["instances"][0]["transform"].size(), 16u);
    // The ground truth is of milk.pcd, and so is the cache (made from it): no warning. A ground
    // truth of another model is scored, with a warning naming both.
    EXPECT_EQ(from_cloud.err.find("warning"), std::string::npos) << from_cloud.err;
    EXPECT_EQ(from_cache.err.find("warning"), std::string::npos) << from_cache.err;
    std::string other_truth = slurp(truth);
    other_truth.replace(other_truth.find("milk.pcd"), 8, "bottle.pcd");
    const Result other = run("recognize --model " + quoted(cache) + " --scene " + quoted(scene) + " --ground-truth " +
                             quoted(dir.write("other.gt.json", other_truth)) + " --fovea " + quoted(fovea));
    EXPECT_EQ(other.exit_code, 0) << other.err;
    EXPECT_NE(other.err.find("is the ground truth of model bottle.pcd, not of milk.pcd"), std::string::npos)
        << other.err;

    // One flipped byte in the middle, and a truncated copy.
    std::string bytes = slurp(cache);
    bytes[bytes.size() / 2] ^= 0x40;
    const auto flipped = dir.write("flipped.mfpcm", bytes);
    const auto truncated = dir.write("truncated.mfpcm", slurp(cache).substr(0, 100));
    for (const auto& damaged : {flipped, truncated}) {
        const Result r = run("recognize --model " + quoted(damaged) + " --scene " + quoted(scene));
        expect_one_line_error(r, 1, damaged.string());
    }
    // A cache made with other model parameters than --params asks for is stale.
    const auto params = dir.write("params.json", R"({"model": {"keypoint_radius": 0.02}})");
    const Result stale = run("recognize --model " + quoted(cache) + " --scene " + quoted(scene) + " --params " + quoted(params));
    expect_one_line_error(stale, 1, "stale cache");
}

// Two models in one run: the scene described once, and per model the instances and score it gets
// alone; the ground truth scores the model it was written for.
TEST(CliRecognize, SeveralModelsFindWhatEachFindsAlone)
{
    MFPC_SHARED_FILE_OR_SKIP(milk, "milk.pcd");
    MFPC_SHARED_FILE_OR_SKIP(bleach, "bleach.pcd");
    MFPC_SHARED_FILE_OR_SKIP(scene, "milk_cartoon_all_small_clorox.pcd");
    MFPC_SHARED_FILE_OR_SKIP(truth, "milk_cartoon_all_small_clorox.gt.json");
    const std::string common = "--threads 2 --json - recognize --scene " + quoted(scene) + " --ground-truth " +
                               quoted(truth) + " --model ";
    const Result both = run(common + quoted(milk) + " --model " + quoted(bleach));
    ASSERT_EQ(both.exit_code, 0) << both.err;
    const auto json = nlohmann::json::parse(both.out);
    ASSERT_EQ(json["models"].size(), 2u);
    EXPECT_GT(json["scene_timings_ms"]["descriptors"].get<double>(), 0.0);
    for (std::size_t m = 0; m < 2; ++m) {
        const Result alone = run(common + quoted(m == 0 ? milk : bleach));
        ASSERT_EQ(alone.exit_code, 0) << alone.err;
        const auto single = nlohmann::json::parse(alone.out);
        const auto& model = json["models"][m];
        EXPECT_EQ(model["instances"].size(), single["instances"].size()) << m;
        EXPECT_EQ(model["counts"]["correspondences"], single["counts"]["correspondences"]) << m;
        for (std::size_t k = 0; k < single["instances"].size(); ++k)
            EXPECT_EQ(model["instances"][k]["transform"], single["instances"][k]["transform"]) << m;
    }
    EXPECT_EQ(json["models"][0]["evaluation"]["instances_true"], 1);
    EXPECT_FALSE(json["models"][1].contains("evaluation"));  // the truth is the milk carton's
}

// --fovea auto as a user meets it on a real scene: the placement in the report, the written config
// reproducing the run, the oracle from the ground truth, and the options that need it refused
// without it.
TEST(CliRecognize, AutoPlacementIsReportedWrittenAndReproduced)
{
    MFPC_SHARED_FILE_OR_SKIP(milk, "milk.pcd");
    MFPC_SHARED_FILE_OR_SKIP(scene, "milk_pair.pcd");
    MFPC_SHARED_FILE_OR_SKIP(truth, "milk_pair.gt.json");
    const test::TempDir dir;
    const std::string common = "--json - recognize --model " + quoted(milk) + " --scene " + quoted(scene) +
                               " --ground-truth " + quoted(truth);
    const Result placed = run(common + " --fovea auto --write-fovea " + quoted(dir / "placed.json"));
    ASSERT_EQ(placed.exit_code, 0) << placed.err;
    const auto json = nlohmann::json::parse(placed.out);
    EXPECT_EQ(json["mode"], "mfpc");
    EXPECT_EQ(json["placement"]["strategy"], "segments");
    EXPECT_GE(json["placement"]["structures"].get<int>(), 2);
    EXPECT_TRUE(json["placement"]["fallback"].is_null());
    EXPECT_EQ(json["evaluation"]["instances_true"], 2);
    EXPECT_EQ(json["evaluation"]["instances_false"], 0);

    const Result again = run(common + " --fovea " + quoted(dir / "placed.json"));
    ASSERT_EQ(again.exit_code, 0) << again.err;
    const auto reproduced = nlohmann::json::parse(again.out);
    EXPECT_TRUE(reproduced["placement"].is_null());
    ASSERT_EQ(reproduced["instances"].size(), json["instances"].size());
    for (std::size_t i = 0; i < json["instances"].size(); ++i)
        EXPECT_EQ(reproduced["instances"][i]["transform"], json["instances"][i]["transform"]) << i;

    const Result oracle = run(common + " --fovea auto --placement oracle");
    ASSERT_EQ(oracle.exit_code, 0) << oracle.err;
    EXPECT_EQ(nlohmann::json::parse(oracle.out)["placement"]["structures"], 2);  // one per carton of the truth

    const std::string plain = "recognize --model " + quoted(milk) + " --scene " + quoted(scene);
    expect_one_line_error(run(plain + " --placement grid"), 2, "--placement without --fovea auto");
    expect_one_line_error(run(plain + " --write-fovea " + quoted(dir / "x.json")), 2, "--write-fovea without auto");
    expect_one_line_error(run(plain + " --fovea auto --placement oracle"), 2, "oracle without a ground truth");
    expect_one_line_error(run(plain + " --fovea auto --placement nowhere"), 2, "unknown placement");
    EXPECT_FALSE(std::filesystem::exists(dir / "x.json"));
}

// foveate --config auto keeps less than the cloud, and a cloud where nothing can be placed passes
// unchanged with a warning instead of failing.
TEST(CliFoveate, AutoConfigPlacesForTheModelsOrSaysWhyNot)
{
    MFPC_SHARED_FILE_OR_SKIP(milk, "milk.pcd");
    MFPC_SHARED_FILE_OR_SKIP(scene, "milk_pair.pcd");
    const test::TempDir dir;
    const Result placed = run("--json - foveate " + quoted(scene) + " --config auto --model " + quoted(milk) +
                              " -o " + quoted(dir / "kept.pcd"));
    ASSERT_EQ(placed.exit_code, 0) << placed.err;
    const auto json = nlohmann::json::parse(placed.out);
    EXPECT_EQ(json["mode"], "mfpc");
    EXPECT_GE(json["structures"].get<int>(), 2);
    EXPECT_LT(json["points_out"].get<long>(), json["points_finite"].get<long>() / 4);
    EXPECT_EQ(json["placement"]["structures"], json["structures"]);

    // A bare table: its plane is removed and nothing stands on it.
    std::string table = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3600\nHEIGHT 1\n"
                        "POINTS 3600\nDATA ascii\n";
    for (int i = 0; i < 60; ++i)
        for (int j = 0; j < 60; ++j) table += std::to_string(-0.3 + 0.01 * i) + " 0.3 " + std::to_string(0.6 + 0.01 * j) + "\n";
    const auto bare = dir.write("table.pcd", table);
    const Result none = run("--json - foveate " + quoted(bare) + " --config auto --model " + quoted(milk) +
                            " --write-fovea " + quoted(dir / "none.json"));
    ASSERT_EQ(none.exit_code, 0) << none.err;
    const auto unchanged = nlohmann::json::parse(none.out);
    EXPECT_EQ(unchanged["placement"]["structures"], 0);
    EXPECT_EQ(unchanged["mode"], "none");
    EXPECT_EQ(unchanged["points_out"], unchanged["points_finite"]);
    EXPECT_NE(none.err.find("without foveation"), std::string::npos) << none.err;
    EXPECT_FALSE(std::filesystem::exists(dir / "none.json"));  // nothing placed, nothing written
    for (const char* args : {" --config auto", " --config auto --model m.pcd --placement oracle",
                             " --model m.pcd", " --config auto --model m.pcd --strict"})
        expect_one_line_error(run("foveate " + quoted(scene) + args), 2, args);
}

}  // namespace
}  // namespace mfpc
