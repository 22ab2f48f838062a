// A synthetic dataset as `mfpc synth` writes it, and the recognition stage on it: the instances of
// a synthetic scene are found from the dataset's own model cache, with and without multifoveation.
#include <ostream>

#include <gtest/gtest.h>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "mfpc/rendering/png_image.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"
#include "test_support.hpp"

namespace mfpc {

// The mode's name in test listings (gtest looks for PrintTo beside the type).
void PrintTo(FoveationMode mode, std::ostream* os) { *os << to_string(mode); }

namespace {

const SyntheticDataset& dataset()
{
    static const SyntheticDataset instance = make_synthetic_dataset(builtin_scene_shapes(), ComposeParams{}, SensorParams{});
    return instance;
}

TEST(SyntheticDataset, FilesHoldTheSceneItsTruthAndItsLabels)
{
    const test::TempDir dir;
    write_synthetic_dataset(dir.path(), dataset());
    const Scan& scan = dataset().scan;

    CloudReadReport report;
    const PointCloud scene = read_cloud(dir / "scene.pcd", &report);
    EXPECT_EQ(report.width, 640u);
    EXPECT_EQ(report.height, 480u);
    EXPECT_EQ(scene.points, scan.cloud.points);
    EXPECT_EQ(scene.source_index, scan.cloud.source_index);

    std::uint32_t width = 0, height = 0;
    const std::vector<std::uint16_t> labels = read_png_gray16(dir / "labels.png", &width, &height);
    EXPECT_EQ(labels, scan.labels);

    // The ground truth names the model file beside it, one instance per carton, with its visible
    // points equal to the label image's count and the carton's half-turn symmetry.
    const GroundTruth truth = read_ground_truth(dir / "scene.gt.json");
    EXPECT_EQ(truth.model, "carton.pcd");
    ASSERT_EQ(truth.instances.size(), 3u);
    for (std::size_t i = 0; i < truth.instances.size(); ++i) {
        const auto count = std::count(labels.begin(), labels.end(), std::uint16_t(label_first_object + i));
        EXPECT_EQ(truth.instances[i].visible_points, long(count));
        EXPECT_GT(count, 500);
        EXPECT_EQ(truth.instances[i].object, "carton");
        EXPECT_EQ(truth.instances[i].symmetry_order, 2);
    }
    const PointCloud model = read_cloud(dir / "carton.pcd");
    EXPECT_TRUE(model.has_normals());
    EXPECT_EQ(model.points, dataset().models[0].points);
    for (const char* shape : {"bottle", "mug", "box", "jug"})
        EXPECT_TRUE(std::filesystem::exists(dir / (std::string(shape) + ".pcd"))) << shape;
    EXPECT_EQ(read_model_cache(dir / "carton.mfpcm").features.size(), dataset().model.features.size());
    const FoveationConfig fovea = read_foveation_config(dir / "fovea.json", FoveaPolicy::strict);
    EXPECT_EQ(fovea.structures.size(), 3u);
}

TEST(SyntheticDataset, EachFoveaHoldsItsInstance)
{
    const SyntheticDataset& data = dataset();
    const Pose world_to_camera = data.scene.camera.inverse();
    for (std::size_t i = 0; i < data.fovea.structures.size(); ++i) {
        const Point centre = world_to_camera * data.scene.objects[i].pose * Point(0, 0, 0.1f);
        EXPECT_EQ(data.fovea.structures[i].level_of(centre), data.fovea.levels()) << "structure " << i;
    }
}

class SyntheticRecognition : public ::testing::TestWithParam<FoveationMode> {};

// The demo's scene (seed 1): every carton found, nothing else, plain and multifoveated.
TEST_P(SyntheticRecognition, FindsEveryInstanceAndNothingElse)
{
    const SyntheticDataset& data = dataset();
    GroundTruth truth;
    for (std::size_t i = 0; i < data.scene.objects.size(); ++i) {
        if (data.scene.objects[i].distractor) continue;
        GroundTruthInstance instance;
        instance.transform = data.scene.camera.inverse() * data.scene.objects[i].pose;
        instance.symmetry_order = data.scene.shapes[0].symmetry_order;
        truth.instances.push_back(instance);
    }
    const SceneFoveation foveation{GetParam() == FoveationMode::none ? nullptr : &data.fovea, GetParam(), 0};
    const RecognitionResult result = recognize(data.model, data.scan.cloud, RecognitionParams{}, foveation);
    const Evaluation evaluation = evaluate(result, data.model, truth);
    EXPECT_EQ(evaluation.instances_true, 3u);
    EXPECT_EQ(evaluation.instances_false, 0u);
    for (std::size_t i = 0; i < result.instances.size(); ++i) {
        EXPECT_LT(evaluation.position_error[i], 0.01f) << "instance " << i;
        EXPECT_LT(evaluation.rotation_error_deg[i], 5.0f) << "instance " << i;
    }
}

INSTANTIATE_TEST_SUITE_P(Modes, SyntheticRecognition, ::testing::Values(FoveationMode::none, FoveationMode::mfpc),
                         [](const auto& info) { return std::string(to_string(info.param)); });

}  // namespace
}  // namespace mfpc
