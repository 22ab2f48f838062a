// The benchmark-set manifest: what it accepts, how it resolves paths, and one error naming the entry
// for everything else; the totals' arithmetic.
#include <cmath>

#include <gtest/gtest.h>

#include "mfpc/core/error.hpp"
#include "mfpc/recognition/dataset.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

std::string error_of(const std::filesystem::path& manifest)
{
    try {
        read_dataset(manifest);
    } catch (const Error& error) {
        return error.what();
    }
    return "";
}

TEST(Dataset, ReadsModelsScenesAndResolvesPaths)
{
    const test::TempDir dir;
    std::filesystem::create_directories(dir / "set");
    const auto manifest = dir.write("set/set.json", R"({
        "name": "tiny", "data_dir": "../data",
        "models": [{"name": "milk", "file": "milk.pcd"}, {"file": "bottle.mfpcm"}],
        "scenes": [{"cloud": "a.pcd", "model": "milk", "ground_truth": "a.gt.json", "fovea": "a_fovea.json", "group": "g"},
                   {"name": "empty room", "model": "bottle", "cloud": "b.pcd", "negative": true}]})");
    const Dataset set = read_dataset(manifest);
    EXPECT_EQ(set.name, "tiny");
    ASSERT_EQ(set.models.size(), 2u);
    EXPECT_EQ(set.models[1].name, "bottle");
    EXPECT_EQ(set.models[0].file, dir / "set" / "../data" / "milk.pcd");
    ASSERT_EQ(set.scenes.size(), 2u);
    EXPECT_EQ(set.scenes[0].name, "a");
    EXPECT_EQ(set.scenes[0].cloud, dir / "set" / "../data" / "a.pcd");
    EXPECT_EQ(set.scenes[0].ground_truth, dir / "set" / "../data" / "a.gt.json");
    EXPECT_EQ(set.scenes[0].fovea, dir / "set" / "a_fovea.json");  // fovea configs beside the manifest
    EXPECT_EQ(set.scenes[0].group, "g");
    EXPECT_EQ(set.scenes[1].name, "empty room");
    EXPECT_TRUE(set.scenes[1].ground_truth.empty());
    // --data-dir overrides the manifest's data_dir.
    EXPECT_EQ(read_dataset(manifest, "/data").scenes[1].cloud, std::filesystem::path("/data/b.pcd"));
}

TEST(Dataset, MalformedManifestsNameTheEntry)
{
    const test::TempDir dir;
    const std::string model = R"("models": [{"file": "m.pcd"}])";
    const std::pair<const char*, std::string> cases[] = {
        {"missing.json", ""},
        {"syntax.json", "{"},
        {"unknown key", R"({"modles": [], "scenes": []})"},
        {"no models", R"({"scenes": [{"cloud": "a.pcd", "negative": true}]})"},
        {"no scenes", "{" + model + "}"},
        {"empty scenes", "{" + model + R"(, "scenes": []})"},
        {"no cloud", "{" + model + R"(, "scenes": [{"negative": true}]})"},
        {"neither truth nor negative", "{" + model + R"(, "scenes": [{"cloud": "a.pcd"}]})"},
        {"both truth and negative", "{" + model + R"(, "scenes": [{"cloud": "a.pcd", "ground_truth": "a.json", "negative": true}]})"},
        {"negative not a boolean", "{" + model + R"(, "scenes": [{"cloud": "a.pcd", "negative": 1}]})"},
        {"unknown model", "{" + model + R"(, "scenes": [{"cloud": "a.pcd", "negative": true, "model": "x"}]})"},
        {"two scenes of one name", "{" + model + R"(, "scenes": [{"cloud": "a.pcd", "negative": true}, {"cloud": "x/a.pcd", "negative": true}]})"},
        {"two models of one name", R"({"models": [{"file": "m.pcd"}, {"file": "x/m.mfpcm"}], "scenes": [{"cloud": "a.pcd", "model": "m", "negative": true}]})"},
        {"model needed", R"({"models": [{"file": "m.pcd"}, {"file": "n.pcd"}], "scenes": [{"cloud": "a.pcd", "negative": true}]})"},
        {"empty file name", "{" + model + R"(, "scenes": [{"cloud": "", "negative": true}]})"},
    };
    int index = 0;
    for (const auto& [what, text] : cases) {
        const std::filesystem::path file =
            text.empty() ? dir / what : dir.write("case" + std::to_string(index++) + ".json", text);
        const std::string message = error_of(file);
        EXPECT_FALSE(message.empty()) << what;
        EXPECT_NE(message.find(file.string()), std::string::npos) << what << ": " << message;
        EXPECT_EQ(message.find('\n'), std::string::npos) << what;
    }
    EXPECT_NE(error_of(dir.write("entry.json", "{" + model + R"(, "scenes": [{"cloud": "a.pcd", "negative": true}, {"cloud": "b.pcd"}]})"))
                  .find("scenes[1]"),
              std::string::npos);
}

TEST(Dataset, TotalsPoolCorrespondencesAndTakeTheMedianTime)
{
    DatasetTotals totals;
    totals.correspondences = 200;
    totals.correct_correspondences = 50;
    totals.possible_correspondences = 40;
    totals.sensitivity_sum = 0.5 * 10 + 0.25 * 30;  // two scenes: 0.5 of 10 and 0.25 of 30 possible pairs
    totals.scene_ms = {30, 10, 20, 40};
    totals.visible = 4;
    totals.visible_found = 3;
    EXPECT_DOUBLE_EQ(totals.precision(), 0.25);
    EXPECT_DOUBLE_EQ(totals.sensitivity(), 12.5 / 40.0);
    EXPECT_DOUBLE_EQ(totals.median_ms(), 25.0);
    EXPECT_DOUBLE_EQ(totals.recall_visible(), 0.75);
    EXPECT_TRUE(std::isnan(DatasetTotals{}.recall_visible()));
    EXPECT_DOUBLE_EQ(DatasetTotals{}.precision(), 0.0);
}

}  // namespace
}  // namespace mfpc

namespace mfpc {
namespace {

// The shipped set over the shared real scenes, with the built-in defaults: no false instance
// anywhere (the two negatives included), plain and foveated, and the scenes the defaults were
// first held to found whole. milk_near_far and milk_floor each still miss one carton (README).
TEST(Dataset, SharedSetWithTheDefaults)
{
    MFPC_SHARED_FILE_OR_SKIP(office, "office1.pcd");
    const Dataset set =
        read_dataset(std::filesystem::path(MFPC_SOURCE_DIR) / "examples/datasets/shared.json", test::shared_data_dir());
    const DatasetReport report = evaluate_dataset(set, RecognitionParams{}, false, "");
    ASSERT_EQ(report.scenes.size(), 8u);  // six plain, two foveated
    for (const SceneOutcome& s : report.scenes) {
        ASSERT_TRUE(s.error.empty()) << s.scene << ": " << s.error;
        EXPECT_EQ(s.evaluation.instances_false, 0u) << s.scene << " " << s.strategy;
        if (s.scene == "milk_pair" || s.scene == "milk_cartoon_all_small_clorox") {
            EXPECT_EQ(s.evaluation.instances_missed, 0u) << s.scene << " " << s.strategy;
        }
#ifndef __SANITIZE_ADDRESS__  // AddressSanitizer's shadow memory and quarantine inflate the resident size
        EXPECT_LT(s.peak_memory, std::size_t(500) << 20) << s.scene;
#endif
    }
}

}  // namespace
}  // namespace mfpc
