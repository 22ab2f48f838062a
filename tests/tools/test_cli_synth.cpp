// `mfpc synth` and `mfpc demo` as a user meets them: the files, reproducible bytes at any thread
// count, and one-line errors.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mfpc/core/foveation_config.hpp"

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

TEST(CliSynth, SameSeedSameBytesOnAnyThreadCount)
{
    const test::TempDir dir;
    const std::string common = "synth --seed 4 --objects 2 --distractors 2 --resolution 320x240";
    const Result one = run("--threads 1 " + common + " -o " + quoted(dir / "one"));
    ASSERT_EQ(one.exit_code, 0) << one.err;
    const Result two = run("--threads 2 --json " + quoted(dir / "summary.json") + " " + common + " -o " + quoted(dir / "two"));
    ASSERT_EQ(two.exit_code, 0) << two.err;
    for (const char* file : {"scene.pcd", "labels.png", "scene.gt.json", "scene.json", "fovea.json", "carton.pcd",
                             "carton.mfpcm"}) {
        const std::string bytes = slurp(dir / "one" / file);
        EXPECT_FALSE(bytes.empty()) << file;
        EXPECT_EQ(bytes, slurp(dir / "two" / file)) << file;
    }
    const auto summary = nlohmann::json::parse(slurp(dir / "summary.json"));
    EXPECT_EQ(summary["width"], 320);
    EXPECT_EQ(summary["objects"].size(), 4u);
    EXPECT_NE(one.out.find("scene points"), std::string::npos);

    const Result other = run(common.substr(0, 13) + "5" + common.substr(14) + " -o " + quoted(dir / "other"));
    ASSERT_EQ(other.exit_code, 0) << other.err;
    EXPECT_NE(slurp(dir / "one" / "scene.pcd"), slurp(dir / "other" / "scene.pcd"));
}

TEST(CliSynth, BadInputIsOneLine)
{
    const test::TempDir dir;
    const std::string out = " -o " + quoted(dir / "out");
    expect_one_line_error(run("synth"), 2, "no output");
    expect_one_line_error(run("synth --resolution 0x480" + out), 2, "zero width");
    expect_one_line_error(run("synth --resolution 640by480" + out), 2, "bad size");
    expect_one_line_error(run("synth --up w" + out), 2, "bad up axis");
    expect_one_line_error(run("synth --object cup" + out), 1, "unknown object");
    expect_one_line_error(run("synth --object " + quoted(dir / "missing.ply") + out), 1, "missing mesh");
    expect_one_line_error(run("synth --object " + quoted(dir.write("broken.obj", "v 0 0 0\nf 1 2 3\n")) + out), 1,
                          "broken mesh");
    expect_one_line_error(run("synth --objects 0 --distractors 0" + out), 1, "nothing to place");
    expect_one_line_error(run("synth --max-incidence 120" + out), 1, "bad sensor");
    // A focal length of 1e-20 pixels once sent rays Embree stops on (an abort): 170 degrees at most.
    expect_one_line_error(run("synth --resolution 64x48 --focal 1e-20" + out), 1, "field of view near 180 degrees");
    expect_one_line_error(run("synth --min-range 5 --max-range 4" + out), 1, "empty range");
    expect_one_line_error(run("synth --model-spacing 0.5" + out), 1, "coarse model spacing");
    expect_one_line_error(run("synth -o " + quoted(dir.write("a_file", "x"))), 1, "output is a file");
    expect_one_line_error(run("demo --object cup -o " + quoted(dir / "demo")), 2, "demo of an unknown object");
    expect_one_line_error(run("demo -o " + quoted(dir / "a_file")), 1, "demo output is a file");
    expect_one_line_error(run("render x.pcd --point-radius 5 -o " + quoted(dir / "x.png")), 2, "huge disc radius");
    expect_one_line_error(run("render x.pcd --point-radius nan -o " + quoted(dir / "x.png")), 2, "NaN disc radius");
    EXPECT_FALSE(std::filesystem::exists(dir / "out" / "scene.pcd"));

    // No instances: no fovea to write, and the rest of the dataset is there.
    const Result empty = run("synth --objects 0 --distractors 2 --resolution 160x120" + out);
    ASSERT_EQ(empty.exit_code, 0) << empty.err;
    EXPECT_TRUE(std::filesystem::exists(dir / "out" / "scene.pcd"));
    EXPECT_FALSE(std::filesystem::exists(dir / "out" / "fovea.json"));
}

TEST(CliSynth, PlacesAScannedCloudModel)
{
    MFPC_SHARED_FILE_OR_SKIP(milk, "milk.pcd");
    const test::TempDir dir;
    const Result r = run("synth --object " + quoted(milk) + " --objects 2 --distractors 1 --resolution 320x240 -o " +
                         quoted(dir / "out"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto truth = nlohmann::json::parse(slurp(dir / "out" / "scene.gt.json"));
    EXPECT_EQ(truth["model"], "milk.pcd");
    EXPECT_EQ(truth["instances"].size(), 2u);
    EXPECT_GT(truth["instances"][0]["visible_points"].get<long>() + truth["instances"][1]["visible_points"].get<long>(),
              100);
}

TEST(CliSynth, SequenceIsWrittenAndEvaluated)
{
    const test::TempDir dir;
    const Result r = run("--json " + quoted(dir / "summary.json") +
                         " synth --sequence 3 --arc 10 --seed 2 --objects 1 --distractors 1 --resolution 160x120 -o " +
                         quoted(dir / "seq"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find("frames"), std::string::npos) << r.out;
    const auto summary = nlohmann::json::parse(slurp(dir / "summary.json"));
    EXPECT_EQ(summary["frames"], 3);
    EXPECT_EQ(summary["heading_step_deg"], 5.0);
    EXPECT_EQ(line_count(slurp(dir / "seq" / "frames.txt")), 3);
    const auto truth = nlohmann::json::parse(slurp(dir / "seq" / "frame_002" / "scene.gt.json"));
    EXPECT_EQ(truth["model"], "../carton.pcd");

    // The manifest is what `mfpc evaluate` reads: every frame runs plain and foveated.
    const Result evaluated =
        run("--json " + quoted(dir / "evaluation.json") + " evaluate --dataset " + quoted(dir / "seq" / "dataset.json"));
    ASSERT_EQ(evaluated.exit_code, 0) << evaluated.err;
    const auto report = nlohmann::json::parse(slurp(dir / "evaluation.json"));
    ASSERT_EQ(report["scenes"].size(), 6u);
    for (const auto& scene : report["scenes"]) {
        EXPECT_TRUE(scene["error"].is_null()) << scene;
        EXPECT_EQ(scene["group"], "sequence");
    }
    EXPECT_EQ(report["scenes"][0]["scene"], "frame_000");
    EXPECT_EQ(report["scenes"][5]["scene"], "frame_002");

    // A frame's ground truth is of the cache's model: scored without a warning.
    const Result recognized = run("recognize --model " + quoted(dir / "seq" / "carton.mfpcm") + " --scene " +
                                  quoted(dir / "seq" / "frame_001" / "scene.pcd") + " --ground-truth " +
                                  quoted(dir / "seq" / "frame_001" / "scene.gt.json"));
    ASSERT_EQ(recognized.exit_code, 0) << recognized.err;
    EXPECT_EQ(recognized.err.find("ground truth of model"), std::string::npos) << recognized.err;

    const std::string out = " -o " + quoted(dir / "bad");
    expect_one_line_error(run("synth --sequence 1" + out), 2, "one frame");
    expect_one_line_error(run("synth --sequence 10001" + out), 2, "too many frames");
    expect_one_line_error(run("synth --arc 30" + out), 2, "--arc without --sequence");
    const Result zero_arc = run("synth --sequence 3 --arc 0" + out);
    expect_one_line_error(zero_arc, 2, "zero arc");
    EXPECT_NE(zero_arc.err.find("--arc"), std::string::npos) << zero_arc.err;
    expect_one_line_error(run("synth --sequence 3 --arc 400" + out), 2, "arc past a turn");
    expect_one_line_error(run("synth --sequence 3 --arc nan" + out), 2, "NaN arc");
    EXPECT_FALSE(std::filesystem::exists(dir / "bad"));
}

TEST(CliDemo, RunsWithNoInputAndFindsTheCartons)
{
    const test::TempDir dir;
    const Result r = run("--json " + quoted(dir / "demo.json") + " demo -o " + quoted(dir / "demo"));
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto summary = nlohmann::json::parse(slurp(dir / "demo.json"));
    ASSERT_EQ(summary["strategies"].size(), 3u);
    for (const auto& strategy : summary["strategies"]) {
        EXPECT_EQ(strategy["instances_true"], 3) << strategy["strategy"];
        EXPECT_EQ(strategy["instances_false"], 0) << strategy["strategy"];
    }
    EXPECT_LT(summary["strategies"][1]["scene_points_used"].get<long>(),
              summary["strategies"][0]["scene_points_used"].get<long>());
    EXPECT_TRUE(std::filesystem::exists(dir / "demo" / "demo.png"));
    // The placed structures are written, and they reproduce the run.
    EXPECT_EQ(summary["strategies"][1]["strategy"], "auto");
    EXPECT_EQ(read_foveation_config(dir / "demo" / "fovea_auto.json").structures.size(),
              summary["strategies"][1]["placement"]["structures"].get<std::size_t>());
    EXPECT_NE(r.out.find("oracle"), std::string::npos);
}

}  // namespace
}  // namespace mfpc
