// A synthetic benchmark set end to end: generated, read as a manifest, evaluated with one scene
// broken, and reported; and `mfpc evaluate` / `mfpc synth-set` as a user meets them.
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "cli_runner.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/recognition/dataset.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/simulation/synthetic_set.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::expect_one_line_error;
using test::quoted;
using test::run;
using test::slurp;

TEST(SyntheticSet, PresetsAreTheDocumentedSensors)
{
    EXPECT_EQ(sensor_preset("kinect").focal_length, 525.0f);
    EXPECT_EQ(sensor_preset("stereo").focal_length, 960.0f);
    EXPECT_EQ(sensor_preset("hd720").width, 1280u);
    EXPECT_EQ(sensor_preset("hd720").height, 720u);
    for (std::string_view name : sensor_preset_names()) EXPECT_NO_THROW(check_sensor(sensor_preset(name))) << name;
    EXPECT_THROW(sensor_preset("lidar"), Error);
}

TEST(SyntheticSet, GeneratedEvaluatedAndReportedWithABrokenScene)
{
    const test::TempDir dir;
    SyntheticSetParams params;
    params.presets = {"kinect"};
    params.scenes = 2;
    params.objects = 1;
    params.distractors = 1;
    params.shapes = {"carton"};
    std::size_t last = 0, total = 0;
    write_synthetic_set(dir / "set", params, [&](std::size_t done, std::size_t all) {
        last = done;
        total = all;
    });
    EXPECT_EQ(last, total);
    EXPECT_EQ(total, 3u);  // one model and two scenes

    Dataset set = read_dataset(dir / "set" / "dataset.json");
    ASSERT_EQ(set.scenes.size(), 2u);
    ASSERT_EQ(set.models.size(), 1u);
    EXPECT_EQ(set.models[0].name, "kinect_carton");
    EXPECT_EQ(set.scenes[0].group, "kinect");
    const GroundTruth truth = read_ground_truth(set.scenes[0].ground_truth);
    ASSERT_EQ(truth.instances.size(), 1u);
    EXPECT_GT(truth.instances[0].visible_fraction, 0.0f);
    EXPECT_LE(truth.instances[0].visible_fraction, 1.0f);

    // A missing file stops the run before it starts, naming the entry.
    DatasetScene missing = set.scenes[0];
    missing.name = "missing";
    missing.cloud = dir / "nowhere.pcd";
    missing.fovea.clear();
    set.scenes.push_back(missing);
    try {
        evaluate_dataset(set, RecognitionParams{}, false, "");
        ADD_FAILURE() << "a missing cloud was not refused";
    } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("scenes[2].cloud: no such file"), std::string::npos) << error.what();
    }
    // A scene whose cloud exists but is not one: a record, and its instance counts as missed.
    set.scenes.back().cloud = dir.write("nowhere.pcd", "# .PCD v0.7\nVERSION 0.7\n");

    DatasetOptions options;
    std::size_t reported = 0;
    const DatasetReport report = evaluate_dataset(set, RecognitionParams{}, false, "", options,
                                                  [&](std::size_t done, std::size_t, const std::string&) { reported = done; });
    // Two scenes plain and foveated, the missing one plain only.
    ASSERT_EQ(report.scenes.size(), 5u);
    EXPECT_EQ(reported, 5u);
    std::size_t failed = 0;
    for (const SceneOutcome& s : report.scenes) {
        if (s.scene == "missing") {
            ++failed;
            EXPECT_NE(s.error.find("nowhere.pcd"), std::string::npos) << s.error;
            continue;
        }
        EXPECT_TRUE(s.error.empty()) << s.error;
        EXPECT_EQ(s.truth.size(), 1u);
        EXPECT_EQ(s.evaluation.instances_true + s.evaluation.instances_missed, 1u);
        EXPECT_GT(s.scene_keypoints, 0u);
        EXPECT_GT(s.peak_memory, 0u);
    }
    EXPECT_EQ(failed, 1u);

    const std::vector<DatasetTally> tallies = tally(report);
    ASSERT_FALSE(tallies.empty());
    EXPECT_EQ(tallies[0].strategy, "plain");
    EXPECT_EQ(tallies[0].kind, "all");
    EXPECT_EQ(tallies[0].totals.scenes, 3u);
    EXPECT_EQ(tallies[0].totals.failed, 1u);
    EXPECT_EQ(tallies[0].totals.truth, 3u);
    EXPECT_GE(tallies[0].totals.instances_missed, 1u);

    const auto json = nlohmann::json::parse(to_json(report));
    EXPECT_EQ(json["scenes"].size(), 5u);
    EXPECT_EQ(json["scenes"][4]["error"].get<std::string>(), report.scenes[4].error);
    EXPECT_FALSE(json["totals"].empty());
    const std::string csv = to_csv(report);
    EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 6);  // a header and a row per run
    // Every row has the header's columns, the failed one too.
    std::istringstream lines(csv);
    std::string header;
    std::getline(lines, header);
    for (std::string row; std::getline(lines, row);) {
        if (row.find('"') != std::string::npos) continue;  // a quoted error may hold commas
        EXPECT_EQ(std::count(row.begin(), row.end(), ','), std::count(header.begin(), header.end(), ',')) << row;
    }
    EXPECT_NE(to_table(report).find("error:"), std::string::npos);

    // Automatic placements run beside, each as its own run with its own totals; the oracle
    // places one structure per instance of the truth, and track follows the group's scenes.
    set.scenes.pop_back();
    options.plain = false;
    options.foveated = false;
    options.placements = {PlacementStrategy::segments, PlacementStrategy::oracle, PlacementStrategy::track};
    const DatasetReport placed = evaluate_dataset(set, RecognitionParams{}, false, "", options);
    ASSERT_EQ(placed.scenes.size(), 6u);
    for (std::size_t i = 0; i < placed.scenes.size(); ++i) {
        const SceneOutcome& s = placed.scenes[i];
        EXPECT_EQ(s.strategy, std::vector<std::string>({"segments", "oracle", "track"})[i % 3]);
        EXPECT_TRUE(s.error.empty()) << s.error;
        EXPECT_TRUE(s.fallback.empty()) << s.fallback;
        EXPECT_GT(s.structures, 0u);
        EXPECT_GE(s.scene_ms, s.placement_ms + s.timings.total - 1e-9);
        if (s.strategy == "oracle") {
            EXPECT_EQ(s.structures, 1u);
        }
        if (s.strategy == "segments") {
            EXPECT_GT(s.placement_ms, 0.0);
        }
    }
    const std::vector<DatasetTally> rows = tally(placed);
    ASSERT_FALSE(rows.empty());
    EXPECT_EQ(rows[0].strategy, "segments");
    EXPECT_EQ(rows[0].totals.scenes, 2u);
    EXPECT_GT(rows[0].totals.structures, 0u);
    const auto placed_json = nlohmann::json::parse(to_json(placed));
    EXPECT_EQ(placed_json["placement"]["strategies"], nlohmann::json({"segments", "oracle", "track"}));
    EXPECT_TRUE(placed_json["scenes"][0].contains("placement_ms"));
    options.placements = {PlacementStrategy::grid, PlacementStrategy::grid};
    EXPECT_THROW(evaluate_dataset(set, RecognitionParams{}, false, "", options), Error);
}

// A set of one scene as `mfpc synth-set --presets PRESET --scenes 1 --first-seed SEED --shapes
// SHAPE` writes it: scene k of the default set is seed k + 1 with shape k of the five.
Dataset one_scene(const test::TempDir& dir, const std::string& preset, std::uint32_t seed, const std::string& shape)
{
    SyntheticSetParams params;
    params.presets = {preset};
    params.scenes = 1;
    params.first_seed = seed;
    params.shapes = {shape};
    write_synthetic_set(dir / "set", params);
    return read_dataset(dir / "set" / "dataset.json");
}

// Two boxes on a Kinect's table (the set's scene kinect_033). With the defaults both are found,
// upside down or not (the box's flip symmetry): the nearer one, 1.35 m away and fully seen, has
// its 20 x 26 cm side turned along the rays, and its true pose was refused for free space (12.5%
// of its points, every one on that side: a side seen edge on projects onto a strip a pixel or two
// wide, which a pose a degree off swings off the box's outline onto pixels that see the table).
// --explain then names where each missed instance was lost: made to fail at each stage in turn by
// its parameters (nothing matches, no Hough maximum is strong enough, no pose covers all of its
// facing side), every instance the run misses is lost there, with the correct correspondences
// grouping had, and none that it finds is said lost.
TEST(SyntheticSet, TwoBoxesFoundAndWhereMissedOnesWereLost)
{
    const test::TempDir dir;
    const Dataset set = one_scene(dir, "kinect", 34, "box");
    DatasetOptions options;
    options.foveated = false;
    options.explain = true;
    RecognitionParams nothing_matches, no_maximum, no_full_cover;
    nothing_matches.match.threshold = 1e-6f;
    no_maximum.grouping.hough_threshold = 1e6f;
    no_full_cover.verify.min_coverage = 1.0f;
    const std::pair<RecognitionParams, std::string> cases[] = {
        {RecognitionParams{}, ""}, {nothing_matches, "no_correspondence"}, {no_maximum, "no_hypothesis"}, {no_full_cover, "coverage"}};
    for (const auto& [params, stage] : cases) {
        SCOPED_TRACE(stage);
        const DatasetReport report = evaluate_dataset(set, params, false, "", options);
        ASSERT_EQ(report.scenes.size(), 1u);
        std::size_t lost = 0;
        for (const TruthOutcome& truth : report.scenes[0].truth) {
            EXPECT_EQ(truth.lost, truth.found ? "" : stage);
            lost += !truth.lost.empty();
            // A lost instance says what grouping had: nothing when nothing matched, some when the
            // maximum was too weak.
            if (truth.lost.empty()) {
                EXPECT_EQ(truth.correct_correspondences, -1);
            } else if (stage == "no_correspondence") {
                EXPECT_EQ(truth.correct_correspondences, 0);
            } else if (stage == "no_hypothesis") {
                EXPECT_GT(truth.correct_correspondences, 0);
            }
        }
        EXPECT_EQ(lost, report.scenes[0].evaluation.instances_missed);
        if (stage.empty()) {
            EXPECT_EQ(report.scenes[0].evaluation.instances_true, 2u);
            EXPECT_EQ(report.scenes[0].evaluation.instances_false, 0u);
        } else {
            EXPECT_GT(lost, 0u);
        }
    }
}

// One scene of the kinect preset recognized plain, with verify.try_turns off and on.
std::pair<Evaluation, Evaluation> unturned_and_turned(const test::TempDir& dir, std::uint32_t seed,
                                                    const std::string& shape)
{
    const Dataset set = one_scene(dir, "kinect", seed, shape);
    DatasetOptions options;
    options.foveated = false;
    RecognitionParams unturned;
    unturned.verify.try_turns = false;
    const DatasetReport before = evaluate_dataset(set, unturned, false, "", options);
    const DatasetReport now = evaluate_dataset(set, RecognitionParams{}, false, "", options);
    EXPECT_EQ(before.scenes.size(), 1u);
    EXPECT_EQ(now.scenes.size(), 1u);
    if (before.scenes.size() != 1 || now.scenes.size() != 1) return {};
    return {before.scenes[0].evaluation, now.scenes[0].evaluation};
}

// A square carton posed a quarter turn off its truth (the set's kinect_015: the gable alone tells
// the poses apart) passes every test on the body the two poses share. Tried from its turns, the
// true pose explains more of the scene and replaces it.
TEST(SyntheticSet, ACartonPosedAQuarterTurnOffIsTurnedBack)
{
    const test::TempDir dir;
    const auto [before, now] = unturned_and_turned(dir, 16, "carton");
    EXPECT_EQ(before.instances_false, 1u);
    EXPECT_EQ(now.instances_false, 0u);
    EXPECT_EQ(now.instances_true, before.instances_true + 1);
}

// Two mugs on a Kinect's table (the set's kinect_002). The nearer one draws its strongest
// hypothesis about a third of a turn about its axis off its truth, with its handle behind its body:
// a pose that fits the whole body and passes every test. Tried from the turns the mug nearly covers
// itself under (about its axis, all but the handle), the true pose, with the handle where the
// sensor saw it, explains more of the scene's pixels and replaces it.
TEST(SyntheticSet, AMugPosedWithItsHandleTurnedAwayIsTurnedBack)
{
    const test::TempDir dir;
    const auto [before, now] = unturned_and_turned(dir, 3, "mug");
    EXPECT_EQ(before.instances_false, 1u);
    EXPECT_EQ(now.instances_false, 0u);
    EXPECT_EQ(now.instances_true, 2u);
}

// Two mugs before a stereo sensor (the set's stereo_027), the nearer one in full view. Its turns
// about its axis fit the body alike and each explains about as many of the noisy depth pixels (the
// poses 15 to 50 degrees off its truth explained 3% more than its truth did): judged where the two
// poses differ, by the handle the sensor saw, the true pose is kept.
TEST(SyntheticSet, AMugBeforeANoisySensorKeepsTheTurnItsHandleShows)
{
    const test::TempDir dir;
    const Dataset set = one_scene(dir, "stereo", 28, "mug");
    DatasetOptions options;
    options.foveated = false;
    const DatasetReport report = evaluate_dataset(set, RecognitionParams{}, false, "", options);
    ASSERT_EQ(report.scenes.size(), 1u);
    EXPECT_EQ(report.scenes[0].evaluation.instances_false, 0u);
    ASSERT_EQ(report.scenes[0].truth.size(), 2u);
    std::size_t in_full_view = 0;
    for (const TruthOutcome& truth : report.scenes[0].truth) {
        if (truth.visible_fraction > 0.99f) {
            ++in_full_view;
            EXPECT_TRUE(truth.found);
        }
    }
    EXPECT_EQ(in_full_view, 1u);
}

TEST(CliEvaluate, BadInputIsOneLine)
{
    const test::TempDir dir;
    expect_one_line_error(run("evaluate"), 2, "no dataset");
    expect_one_line_error(run("evaluate --dataset " + quoted(dir / "missing.json")), 1, "missing manifest");
    expect_one_line_error(run("evaluate --dataset " + quoted(dir.write("bad.json", "{\"models\": 3}"))), 1,
                          "malformed manifest");
    const auto manifest = dir.write("set.json", R"({"models": [{"file": "m.pcd"}], "scenes": [{"cloud": "a.pcd", "negative": true}]})");
    expect_one_line_error(run("evaluate --runs some --dataset " + quoted(manifest)), 2, "bad --runs");
    expect_one_line_error(run("evaluate --min-visible 2 --dataset " + quoted(manifest)), 2, "bad --min-visible");
    expect_one_line_error(run("evaluate --dataset " + quoted(manifest)), 1, "missing model file");
    // A model that exists but cannot be read makes every scene of it a failure record: a warning, exit 0.
    dir.write("m.pcd", "not a cloud");
    dir.write("a.pcd", "not a cloud either");
    const test::Result result = run("--json " + quoted(dir / "out.json") + " evaluate --dataset " + quoted(manifest));
    EXPECT_EQ(result.exit_code, 0) << result.err;
    EXPECT_NE(result.err.find("m.pcd"), std::string::npos);
    const auto json = nlohmann::json::parse(slurp(dir / "out.json"));
    EXPECT_FALSE(json["scenes"][0]["error"].is_null());

    expect_one_line_error(run("synth-set --presets lidar -o " + quoted(dir / "s")), 1, "unknown preset");
    expect_one_line_error(run("synth-set --scenes 0 -o " + quoted(dir / "s")), 2, "no scenes");
    expect_one_line_error(run("synth-set --shapes cup -o " + quoted(dir / "s")), 1, "unknown shape");
}

}  // namespace
}  // namespace mfpc
