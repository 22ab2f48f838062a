// Automatic fovea placement on synthetic scenes, whose objects' boxes are known exactly: every
// strategy's structures hold the objects, placement is deterministic at any thread count, a scene
// where nothing can be placed falls back and says so, and recognition on placed foveae finds what
// it finds on the ground truth's.
#include <algorithm>
#include <cmath>
#include <limits>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "mfpc/core/error.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/placement.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

// The demo's scene (seed 1: three cartons among three distractors on a table), at VGA.
const SyntheticDataset& dataset()
{
    static const SyntheticDataset instance = make_synthetic_dataset(builtin_scene_shapes(), ComposeParams{}, SensorParams{});
    return instance;
}

std::vector<PlacedInstance> truth_of(const SyntheticDataset& data)
{
    std::vector<PlacedInstance> truth;
    for (const SceneObject& object : data.scene.objects)
        if (!object.distractor) truth.push_back({0, data.scene.camera.inverse() * object.pose});
    return truth;
}

GroundTruth ground_truth_of_scene(const SyntheticDataset& data)
{
    GroundTruth truth;
    for (const PlacedInstance& placed : truth_of(data)) {
        GroundTruthInstance instance;
        instance.transform = placed.transform;
        instance.symmetry_order = data.scene.shapes[0].symmetry_order;
        truth.instances.push_back(instance);
    }
    return truth;
}

PlacementResult place(PlacementStrategy strategy, const PointCloud& cloud, PlacementTrack* track = nullptr,
                      PlacementParams params = {})
{
    params.strategy = strategy;
    const Model* const models[] = {&dataset().model};
    const std::vector<PlacedInstance> truth = truth_of(dataset());
    return place_foveae(cloud, models, RecognitionParams{}, params, truth, track);
}

Box fovea_of(const FoveatedStructure& structure) { return structure.level_box(structure.levels); }

// The object's visible points: its label's pixels in the scan.
Box visible_box(const SyntheticDataset& data, std::size_t object)
{
    Box box = bounding_box({});
    for (std::size_t i = 0; i < data.scan.cloud.size(); ++i)
        if (data.scan.labels[data.scan.cloud.source_index[i]] == label_first_object + object)
            box.extend(data.scan.cloud.points[i]);
    return box;
}

TEST(Placement, SegmentsPutsEveryObjectInsideAFovea)
{
    const SyntheticDataset& data = dataset();
    const PlacementResult result = place(PlacementStrategy::segments, data.scan.cloud);
    EXPECT_TRUE(result.fallback.empty()) << result.fallback;
    EXPECT_GE(result.planes, 1u);  // the table
    // Each object stands apart: one cluster, hence one structure, per object.
    EXPECT_EQ(result.config.structures.size(), data.scene.objects.size());
    for (std::size_t i = 0; i < data.scene.objects.size(); ++i) {
        const Box seen = visible_box(data, i);
        ASSERT_TRUE(seen.valid()) << "object " << i;
        const bool held = std::any_of(result.config.structures.begin(), result.config.structures.end(),
                                      [&](const FoveatedStructure& s) { return fovea_of(s).contains(seen.center()); });
        EXPECT_TRUE(held) << "object " << i;
    }
    EXPECT_EQ(result.objects.size(), result.config.structures.size());
    EXPECT_GT(result.fovea_fraction, 0.0);
    EXPECT_LT(result.fovea_fraction, PlacementParams{}.max_fovea_fraction);
}

TEST(Placement, StructuresAreSizedFromTheSceneParameters)
{
    const RecognitionParams params;
    const PlacementParams placement;
    const PlacementResult result = place(PlacementStrategy::segments, dataset().scan.cloud);
    ASSERT_FALSE(result.config.structures.empty());
    EXPECT_EQ(result.config.levels(), placement.levels);
    EXPECT_EQ(result.config.downsample, Downsample::voxel);
    for (std::size_t i = 0; i < result.config.structures.size(); ++i) {
        const FoveatedStructure& s = result.config.structures[i];
        EXPECT_EQ(s.density_fovea, params.scene.resolution);
        EXPECT_EQ(s.density_outer, placement.outer_density_factor * params.scene.resolution);
        EXPECT_EQ(s.keypoint_radius_fovea, params.scene.keypoint_radius);
        EXPECT_EQ(s.keypoint_radius_outer, placement.outer_density_factor * params.scene.keypoint_radius);
        // The fovea is the object's box grown by the margin, the outer box that grown again.
        const Box& object = result.objects[i];
        const Eigen::Vector3f fovea = object.size().array() + 2 * placement.fovea_margin;
        EXPECT_TRUE(s.fovea_size.isApprox(fovea, 1e-5f));
        EXPECT_TRUE(s.outer_size.isApprox(Eigen::Vector3f(fovea.array() + 2 * placement.outer_margin), 1e-5f));
        EXPECT_TRUE(s.fovea_center().isApprox(object.center(), 1e-5f));
    }
    // The config reads back as it was written.
    const FoveationConfig back = parse_foveation_config(to_json(result.config), "placed", FoveaPolicy::strict);
    EXPECT_EQ(to_json(back), to_json(result.config));
}

TEST(Placement, EveryStrategyGivesTheSameConfigAtAnyThreadCount)
{
    for (const PlacementStrategy strategy : {PlacementStrategy::segments, PlacementStrategy::coarse,
                                             PlacementStrategy::grid, PlacementStrategy::oracle}) {
        std::string one, two;
        {
            const tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
            one = to_json(place(strategy, dataset().scan.cloud).config);
        }
        {
            const tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 2);
            two = to_json(place(strategy, dataset().scan.cloud).config);
        }
        EXPECT_EQ(one, two) << to_string(strategy);
    }
}

TEST(Placement, OracleHoldsEachInstanceInItsFovea)
{
    const SyntheticDataset& data = dataset();
    const PlacementResult result = place(PlacementStrategy::oracle, data.scan.cloud);
    const std::vector<PlacedInstance> truth = truth_of(data);
    ASSERT_EQ(result.config.structures.size(), truth.size());
    for (std::size_t i = 0; i < truth.size(); ++i)
        EXPECT_TRUE(fovea_of(result.config.structures[i]).contains(placed_model_box(data.model, truth[i].transform)));
}

TEST(Placement, CoarseAndGridCoverTheInstances)
{
    const SyntheticDataset& data = dataset();
    for (const PlacementStrategy strategy : {PlacementStrategy::coarse, PlacementStrategy::grid}) {
        const PlacementResult result = place(strategy, data.scan.cloud);
        ASSERT_TRUE(result.fallback.empty()) << result.fallback;
        for (const PlacedInstance& instance : truth_of(data)) {
            const Point centre = instance.transform * model_centroid(data.model);
            const bool held = std::any_of(result.config.structures.begin(), result.config.structures.end(),
                                          [&](const FoveatedStructure& s) { return s.level_of(centre) >= 0; });
            EXPECT_TRUE(held) << to_string(strategy);
        }
    }
    EXPECT_GT(place(PlacementStrategy::coarse, data.scan.cloud).hypotheses, 0u);
}

TEST(Placement, NothingToPlaceFallsBackAndSaysSo)
{
    // A bare table: one plane, removed, and nothing on it.
    PointCloud table;
    for (int i = 0; i < 200; ++i)
        for (int j = 0; j < 200; ++j) table.points.emplace_back(-0.5f + 0.005f * i, 0.3f, 0.6f + 0.005f * j);
    const PlacementResult bare = place(PlacementStrategy::segments, table);
    EXPECT_TRUE(bare.config.structures.empty());
    EXPECT_EQ(bare.planes, 1u);
    EXPECT_NE(bare.fallback.find("without foveation"), std::string::npos) << bare.fallback;

    // No finite point at all, for every strategy but the oracle, which places from the truth.
    PointCloud empty;
    empty.points.assign(10, Point::Constant(std::numeric_limits<float>::quiet_NaN()));
    for (const PlacementStrategy strategy :
         {PlacementStrategy::segments, PlacementStrategy::grid, PlacementStrategy::coarse}) {
        PlacementResult result;
        ASSERT_NO_THROW(result = place(strategy, empty)) << to_string(strategy);
        EXPECT_TRUE(result.config.structures.empty());
        EXPECT_FALSE(result.fallback.empty());
    }

    // Foveae that would hold more of the scene than foveation saves: the plain pipeline.
    PlacementParams greedy;
    greedy.max_fovea_fraction = 0.0f;
    const PlacementResult result = place(PlacementStrategy::segments, dataset().scan.cloud, nullptr, greedy);
    EXPECT_TRUE(result.config.structures.empty());
    EXPECT_NE(result.fallback.find("would hold"), std::string::npos) << result.fallback;
}

TEST(Placement, TrackFollowsTheInstancesAndSearchesWhenDue)
{
    const SyntheticDataset& data = dataset();
    const Model* const models[] = {&data.model};
    PlacementParams params;
    params.track_refresh = 3;
    PlacementTrack track;
    // Frame 0 follows nothing: it searches, as segments.
    const PlacementResult first = place(PlacementStrategy::track, data.scan.cloud, &track, params);
    EXPECT_TRUE(first.searched);
    EXPECT_EQ(first.followed, 0u);
    EXPECT_EQ(to_json(first.config), to_json(place(PlacementStrategy::segments, data.scan.cloud).config));
    // One instance found: the next frame places only its cluster.
    const std::vector<PlacedInstance> truth = truth_of(data);
    track_update(track, models, std::span(truth).first(1), params.track_refresh);
    const PlacementResult second = place(PlacementStrategy::track, data.scan.cloud, &track, params);
    EXPECT_FALSE(second.searched);
    EXPECT_EQ(second.followed, 1u);
    // Its cluster, and at most the neighbour whose centre lies within the motion margin of it.
    ASSERT_GE(second.config.structures.size(), 1u);
    EXPECT_LT(second.config.structures.size(), first.config.structures.size());
    const Point followed = truth[0].transform * model_centroid(data.model);
    EXPECT_TRUE(std::any_of(second.config.structures.begin(), second.config.structures.end(),
                            [&](const FoveatedStructure& s) { return fovea_of(s).contains(followed); }));
    // Not found again: still followed where it was, until the frame due for a search.
    track_update(track, models, {}, params.track_refresh);
    const PlacementResult third = place(PlacementStrategy::track, data.scan.cloud, &track, params);
    EXPECT_EQ(third.followed, 1u);
    EXPECT_FALSE(third.searched);
    track_update(track, models, {}, params.track_refresh);
    const PlacementResult fourth = place(PlacementStrategy::track, data.scan.cloud, &track, params);
    EXPECT_TRUE(fourth.searched);  // frame 3: due
    EXPECT_EQ(fourth.config.structures.size(), first.config.structures.size());
    EXPECT_THROW(place(PlacementStrategy::track, data.scan.cloud, nullptr), Error);
}

TEST(Placement, RecognitionOnPlacedFoveaeFindsWhatTheOracleFinds)
{
    const SyntheticDataset& data = dataset();
    const GroundTruth truth = ground_truth_of_scene(data);
    for (const PlacementStrategy strategy : {PlacementStrategy::segments, PlacementStrategy::oracle}) {
        const PlacementResult placed = place(strategy, data.scan.cloud);
        const SceneFoveation foveation{&placed.config, FoveationMode::mfpc, 0};
        const RecognitionResult result = recognize(data.model, data.scan.cloud, RecognitionParams{}, foveation);
        const Evaluation evaluation = evaluate(result, data.model, truth);
        EXPECT_EQ(evaluation.instances_true, truth.instances.size()) << to_string(strategy);
        EXPECT_EQ(evaluation.instances_false, 0u) << to_string(strategy);
        // Fewer points described than the plain pipeline's voxels: what placement is for.
        EXPECT_LT(result.counts.scene_points_used, data.scan.cloud.size() / 4) << to_string(strategy);
    }
}

TEST(Placement, BadParametersAndInputsAreRefusedByName)
{
    auto refused = [](PlacementParams params, const char* key) {
        try {
            check_placement_params(params, "p");
        } catch (const Error& error) {
            EXPECT_EQ(error.where(), std::string("p: ") + key);
            return;
        }
        ADD_FAILURE() << key << " accepted";
    };
    PlacementParams p;
    p.levels = 0;
    refused(p, "levels");
    p = {};
    p.voxel = 0;
    refused(p, "voxel");
    p = {};
    p.outer_margin = std::numeric_limits<float>::infinity();
    refused(p, "outer_margin");
    p = {};
    p.min_plane_fraction = 1.5f;
    refused(p, "min_plane_fraction");
    p = {};
    p.max_fovea_fraction = -0.1f;
    refused(p, "max_fovea_fraction");
    p = {};
    p.track_refresh = 0;
    refused(p, "track_refresh");
    EXPECT_THROW(parse_placement_strategy("somewhere"), Error);
    EXPECT_EQ(parse_placement_strategy("track"), PlacementStrategy::track);

    const PointCloud& cloud = dataset().scan.cloud;
    EXPECT_THROW(place_foveae(cloud, {}, RecognitionParams{}, PlacementParams{}), Error);
    const Model* const null_model[] = {nullptr};
    EXPECT_THROW(place_foveae(cloud, null_model, RecognitionParams{}, PlacementParams{}), Error);
    const Model* const models[] = {&dataset().model};
    const PlacedInstance stray[] = {{3, Pose::Identity()}};
    PlacementParams oracle;
    oracle.strategy = PlacementStrategy::oracle;
    EXPECT_THROW(place_foveae(cloud, models, RecognitionParams{}, oracle, stray), Error);
}

}  // namespace
}  // namespace mfpc
