// The experiment runner: its config, and the identities between strategies that must hold on the
// shared milk_pair scene (paper Table 7): |raw| = |FCRM| + |FCLM| before downsampling, and
// MFPC = raw - redundant points.
#include <gtest/gtest.h>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/recognition/experiment.hpp"
#include "mfpc/recognition/model.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::TempDir;

std::string config_error(const TempDir& dir, const std::string& text)
{
    const auto path = dir.write("experiment.json", text);
    try {
        read_experiment_config(path);
    } catch (const Error& error) {
        const std::string what = error.what();
        EXPECT_EQ(what.find('\n'), std::string::npos) << what;
        return what.substr(what.find(": ") + 2);
    }
    ADD_FAILURE() << "read without an error: " << text;
    return {};
}

TEST(ExperimentConfig, ShippedMilkPairConfigReads)
{
    const ExperimentConfig config =
        read_experiment_config(std::filesystem::path(MFPC_SOURCE_DIR) / "examples/experiments/milk_pair.json");
    ASSERT_EQ(config.strategies.size(), 9u);
    EXPECT_EQ(config.runs, 15);
    EXPECT_EQ(config.strategies[7].placement, PlacementStrategy::segments);
    EXPECT_EQ(config.strategies[8].placement, PlacementStrategy::oracle);
    EXPECT_EQ(config.strategies[size_t(config.reference)].name, "MFPC");
    EXPECT_EQ(config.strategies[4].structure, 1);
    EXPECT_TRUE(config.strategies[6].serial);
    EXPECT_EQ(config.strategies[6].fovea.structures.size(), 2u);
}

TEST(ExperimentConfig, BadConfigsNameTheKey)
{
    TempDir dir;
    const std::string fovea = std::string(MFPC_SOURCE_DIR) + "/examples/configs/milk_pair_two.json";
    const std::string files = "\"model\": \"m.pcd\", \"scene\": \"s.pcd\", \"ground_truth\": \"g.json\"";
    auto with = [&](const std::string& strategies, const std::string& extra = "") {
        return "{" + files + extra + ", \"strategies\": [" + strategies + "]}";
    };
    EXPECT_EQ(config_error(dir, "{\"scene\": \"s.pcd\"}"), "model: missing");
    EXPECT_EQ(config_error(dir, with("{\"name\": \"a\", \"mode\": \"none\"}", ", \"colour\": 1")), "colour: unknown key");
    EXPECT_EQ(config_error(dir, with("")), "strategies: must be a non-empty array");
    EXPECT_EQ(config_error(dir, with("{\"name\": \"a\", \"mode\": \"sideways\"}")).rfind("strategies[0].mode", 0), 0u);
    EXPECT_EQ(config_error(dir, with("{\"name\": \"a\", \"mode\": \"mfpc\"}")), "strategies[0].fovea: missing");
    EXPECT_EQ(config_error(dir, with("{\"name\": \"a\", \"mode\": \"none\", \"fovea\": \"" + fovea + "\"}")),
              "strategies[0].fovea: mode none foveates nothing: remove the fovea or choose a mode");
    EXPECT_EQ(config_error(dir, with("{\"name\": \"a\", \"mode\": \"single\", \"fovea\": \"" + fovea + "\"}")),
              "strategies[0].structure: missing: " + fovea + " has 2 structures");
    EXPECT_EQ(config_error(dir, with("{\"name\": \"a\", \"mode\": \"single\", \"fovea\": \"" + fovea +
                                     "\", \"structure\": 2}")),
              "strategies[0].structure: must name a structure of " + fovea + " (0..1)");
    EXPECT_EQ(config_error(dir, with("{\"name\": \"a\", \"mode\": \"none\"}, {\"name\": \"a\", \"mode\": \"none\"}")),
              "strategies[1].name: 'a' is used twice");
    EXPECT_EQ(config_error(dir, with("{\"name\": \"a\", \"mode\": \"none\"}", ", \"runs\": 0")),
              "runs: must be an integer 1..100000");
    EXPECT_EQ(config_error(dir, with("{\"name\": \"a\", \"mode\": \"none\"}", ", \"reference\": \"b\"")),
              "reference: 'b' names no strategy");
}

// Keys given twice, deep nesting and syntax errors read as in every MFPC JSON reader
// (check_json_text; its own tests are in tests/core).
TEST(ExperimentConfig, RejectsDuplicateKeysDeepNestingAndBadJson)
{
    TempDir dir;
    const std::string files = "\"model\": \"m.pcd\", \"scene\": \"s.pcd\", \"ground_truth\": \"g.json\"";
    EXPECT_EQ(config_error(dir, "{" + files + ", \"model\": \"n.pcd\", \"strategies\": []}"), "model: duplicate key");
    EXPECT_EQ(config_error(dir, "{" + files +
                                    ", \"strategies\": [{\"name\": \"a\", \"mode\": \"none\", \"mode\": \"mfpc\"}]}"),
              "strategies[0].mode: duplicate key");
    // Inline parameters are part of the same document: their duplicates are named by full path.
    EXPECT_EQ(config_error(dir, "{" + files + ", \"params\": {\"match_k\": 1, \"match_k\": 2}, \"strategies\": []}"),
              "params.match_k: duplicate key");
    EXPECT_EQ(config_error(dir, "{" + files + ", \"strategies\": " + std::string(100, '[') + std::string(100, ']') + "}"),
              "invalid JSON: nested deeper than 64 levels");
    // nlohmann's "[json.exception.parse_error.101] " prefix is left out.
    const std::string syntax = config_error(dir, "{\"model\": \n}");
    EXPECT_EQ(syntax.rfind("invalid JSON: parse error at line 2", 0), 0u) << syntax;
}

TEST(Experiment, StrategyIdentitiesHoldOnMilkPair)
{
    MFPC_SHARED_FILE_OR_SKIP(model_path, "milk.pcd");
    MFPC_SHARED_FILE_OR_SKIP(scene_path, "milk_pair.pcd");
    MFPC_SHARED_FILE_OR_SKIP(truth_path, "milk_pair.gt.json");
    ExperimentConfig config =
        read_experiment_config(std::filesystem::path(MFPC_SOURCE_DIR) / "examples/experiments/milk_pair.json");
    config.runs = 1;
    // raw, MFPC, FCRM, FCLM, FCRM+FCLM
    config.strategies = {config.strategies[1], config.strategies[2], config.strategies[4], config.strategies[5],
                         config.strategies[6]};
    const Model model = prepare_model(read_cloud(model_path), config.params.model, model_path.string());
    const auto outcomes =
        run_experiment(config, model, read_cloud(scene_path), read_ground_truth(truth_path), [](int, int) {});
    ASSERT_EQ(outcomes.size(), 5u);
    const RecognitionCounts& raw = outcomes[0].counts;
    const RecognitionCounts& mfpc = outcomes[1].counts;
    const RecognitionCounts& right = outcomes[2].counts;
    const RecognitionCounts& left = outcomes[3].counts;
    EXPECT_EQ(raw.scene_points_foveated, right.scene_points_foveated + left.scene_points_foveated);
    EXPECT_GT(raw.redundant_points, 0u);  // the two structures overlap
    EXPECT_EQ(mfpc.scene_points_foveated, raw.scene_points_foveated - raw.redundant_points);
    // The serial strategy is the two single runs added up.
    EXPECT_EQ(outcomes[4].counts.scene_points_foveated, raw.scene_points_foveated);
    EXPECT_EQ(outcomes[4].counts.scene_points_used, right.scene_points_used + left.scene_points_used);
    EXPECT_EQ(outcomes[4].counts.correspondences, right.correspondences + left.correspondences);
    // MFPC finds both cartons and nothing else (the recognition issue's acceptance).
    EXPECT_EQ(outcomes[1].evaluation.instances_true, 2u);
    EXPECT_EQ(outcomes[1].evaluation.instances_false, 0u);
    for (const StrategyOutcome& outcome : outcomes) EXPECT_EQ(outcome.timings.size(), 1u);
}

}  // namespace
}  // namespace mfpc
