// A synthetic sequence: a camera orbiting a table of fixed objects, written frame by frame with
// the models once above the frames, and read back as a dataset manifest and a frame list.
#include <cmath>
#include <numbers>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "cli_runner.hpp"
#include "mfpc/batch/batch.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/recognition/dataset.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/simulation/synthetic_sequence.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::slurp;

// A small table (2 cartons, 1 distractor) at 160x120, so that a few frames take well under a second.
ComposeParams small_table()
{
    ComposeParams compose;
    compose.seed = 3;
    compose.objects = 2;
    compose.distractors = 1;
    return compose;
}

SensorParams small_sensor()
{
    SensorParams sensor;
    sensor.width = 160;
    sensor.height = 120;
    return sensor;
}

SequenceParams few_frames()
{
    SequenceParams sequence;
    sequence.frames = 3;
    sequence.arc_deg = 12.0f;
    return sequence;
}

Pose pose_of(const nlohmann::json& values) { return pose_from_row_major(values.get<std::vector<double>>()); }

// The camera's heading about the centre (radians, counter-clockwise seen from above), elevation
// (radians) and distance.
struct Orbit {
    double heading, elevation, distance;
};

Orbit orbit_of(const Pose& camera, const Eigen::Vector3f& centre)
{
    const Eigen::Vector3d offset = (camera.translation() - centre).cast<double>();
    return {std::atan2(offset.y(), offset.x()), std::asin(offset.z() / offset.norm()), offset.norm()};
}

double wrapped(double angle) { return std::remainder(angle, 2.0 * std::numbers::pi); }

// The sequence the tests read, written once.
class SyntheticSequenceFiles : public ::testing::Test {
protected:
    static void SetUpTestSuite()
    {
        dir_ = new test::TempDir;
        write_synthetic_sequence(dir_->path(), builtin_scene_shapes(), small_table(), small_sensor(), few_frames(),
                                 0.002f, RecognitionParams{}.model, [](std::size_t done, std::size_t total) {
                                     progress_.push_back({done, total});
                                 });
    }
    static void TearDownTestSuite()
    {
        delete dir_;
        dir_ = nullptr;
    }
    static const std::filesystem::path& dir() { return dir_->path(); }

    static test::TempDir* dir_;
    static std::vector<std::pair<std::size_t, std::size_t>> progress_;
};

test::TempDir* SyntheticSequenceFiles::dir_ = nullptr;
std::vector<std::pair<std::size_t, std::size_t>> SyntheticSequenceFiles::progress_;

TEST(SyntheticSequence, ParametersAreCheckedNamingTheField)
{
    auto field_of = [](const SequenceParams& params) {
        try {
            check_sequence_params(params);
        } catch (const Error& error) {
            return error.where();
        }
        return std::string("accepted");
    };
    EXPECT_EQ(field_of({}), "accepted");
    EXPECT_EQ(field_of({2, 360.0f}), "accepted");
    EXPECT_EQ(field_of({10000, 0.001f}), "accepted");
    EXPECT_EQ(field_of({0, 60.0f}), "frames");
    EXPECT_EQ(field_of({1, 60.0f}), "frames");
    EXPECT_EQ(field_of({10001, 60.0f}), "frames");
    for (float arc : {0.0f, -5.0f, 360.5f, std::numeric_limits<float>::quiet_NaN(),
                      std::numeric_limits<float>::infinity()})
        EXPECT_EQ(field_of({30, arc}), "arc_deg") << arc;

    // Refused before any work: the directory is not even made.
    const test::TempDir dir;
    EXPECT_THROW(write_synthetic_sequence(dir / "seq", builtin_scene_shapes(), small_table(), small_sensor(), {1, 60.0f}),
                 Error);
    EXPECT_FALSE(std::filesystem::exists(dir / "seq"));
    const SyntheticScene scene = compose_scene(builtin_scene_shapes(), small_table());
    EXPECT_THROW(sequence_camera(scene, few_frames(), 3), Error);  // frames 0..2
}

TEST(SyntheticSequence, CameraOrbitsTheCentreByTheHeadingStep)
{
    const SyntheticScene scene = compose_scene(builtin_scene_shapes(), ComposeParams{});
    const SequenceParams sequence{7, 30.0f};
    EXPECT_DOUBLE_EQ(sequence_heading_step_deg(sequence), 5.0);
    const Eigen::Vector3f centre = objects_centre(scene);
    EXPECT_TRUE(sequence_camera(scene, sequence, 0).isApprox(scene.camera, 0.0f));  // bit for bit
    const Orbit first = orbit_of(scene.camera, centre);
    Pose previous = scene.camera;
    for (std::uint32_t k = 1; k < sequence.frames; ++k) {
        const Pose camera = sequence_camera(scene, sequence, k);
        const Orbit now = orbit_of(camera, centre);
        EXPECT_NEAR(wrapped(now.heading - first.heading), k * 5.0 * std::numbers::pi / 180.0, 1e-5) << k;
        EXPECT_NEAR(now.elevation, first.elevation, 1e-5) << k;
        EXPECT_NEAR(now.distance, first.distance, 1e-5) << k;
        // Still a camera looking at the centre with a level x axis, walking to its right.
        const Eigen::Vector3f forward = camera.linear().col(2);
        EXPECT_NEAR(forward.dot((centre - camera.translation()).normalized()), 1.0, 1e-5) << k;
        EXPECT_NEAR(camera.linear().col(0).z(), 0.0, 1e-5) << k;
        EXPECT_NEAR((camera.linear().transpose() * camera.linear() - Eigen::Matrix3f::Identity()).norm(), 0.0, 1e-5);
        EXPECT_GT((camera.translation() - previous.translation()).dot(previous.linear().col(0)), 0.0f) << k;
        previous = camera;
    }
    EXPECT_NE(sequence_frame_seed(1, 0), sequence_frame_seed(1, 1));
    EXPECT_EQ(sequence_frame_seed(1, 0), 1u);
    EXPECT_EQ(sequence_frame_directory(7, 30), "frame_007");
    EXPECT_EQ(sequence_frame_directory(7, 10000), "frame_0007");
}

TEST(SyntheticSequence, FrameZeroIsTheScanOfTheComposedScene)
{
    // The sequence's first frame is the scene `mfpc synth` makes of the same seed.
    const SyntheticScene scene = compose_scene(builtin_scene_shapes(), small_table());
    const SyntheticDataset single = scan_synthetic_scene(scene, small_sensor(), small_table().seed);
    const SyntheticDataset frame = make_sequence_frame(scene, small_sensor(), small_table().seed, few_frames(), 0);
    EXPECT_EQ(frame.scan.cloud.points, single.scan.cloud.points);
    EXPECT_EQ(frame.scan.labels, single.scan.labels);
    ASSERT_TRUE(frame.frame.has_value());
    EXPECT_EQ(frame.frame->index, 0u);
    EXPECT_EQ(frame.seed, small_table().seed);
    EXPECT_TRUE(frame.models.empty());
    EXPECT_EQ(frame.visible_fraction.size(), scene.objects.size());
    // The next frame sees the table from elsewhere, with noise of its own.
    const SyntheticDataset next = make_sequence_frame(scene, small_sensor(), small_table().seed, few_frames(), 1);
    EXPECT_NE(next.scan.cloud.points, single.scan.cloud.points);
    EXPECT_NE(next.frame->noise_seed, frame.frame->noise_seed);
}

TEST_F(SyntheticSequenceFiles, FramesAndListAreWrittenInOrder)
{
    ASSERT_FALSE(progress_.empty());
    EXPECT_EQ(progress_.back().first, 4u);  // the models, then 3 frames
    EXPECT_EQ(progress_.back().second, 4u);

    std::istringstream list(slurp(dir() / "frames.txt"));
    std::vector<std::string> lines;
    for (std::string line; std::getline(list, line);) lines.push_back(line);
    EXPECT_EQ(lines, (std::vector<std::string>{"frame_000/scene.pcd", "frame_001/scene.pcd", "frame_002/scene.pcd"}));
    // What `mfpc batch --scenes LIST` makes of it.
    const std::vector<std::filesystem::path> scenes = list_scenes({(dir() / "frames.txt").string()});
    ASSERT_EQ(scenes.size(), 3u);
    EXPECT_EQ(scenes[2], dir() / "frame_002/scene.pcd");

    // The models once above the frames, the scan's files in each frame.
    for (const char* model : {"carton.pcd", "carton.mfpcm", "bottle.pcd", "mug.pcd", "box.pcd", "jug.pcd"})
        EXPECT_TRUE(std::filesystem::exists(dir() / model)) << model;
    std::size_t frames = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir()))
        if (entry.is_directory()) ++frames;
    EXPECT_EQ(frames, 3u);
    for (const std::string frame : {"frame_000", "frame_001", "frame_002"}) {
        for (const char* file : {"scene.pcd", "scene.gt.json", "labels.png", "scene.json", "fovea.json", "fovea_all.json"})
            EXPECT_TRUE(std::filesystem::exists(dir() / frame / file)) << frame << "/" << file;
        EXPECT_FALSE(std::filesystem::exists(dir() / frame / "carton.pcd")) << frame;
        EXPECT_FALSE(std::filesystem::exists(dir() / frame / "carton.mfpcm")) << frame;
        CloudReadReport report;
        read_cloud(dir() / frame / "scene.pcd", &report);
        EXPECT_EQ(report.width, 160u);
        EXPECT_EQ(report.height, 120u);
    }

    // The manifest: the cache, the frames in order, each with its fovea.
    const Dataset set = read_dataset(dir() / "dataset.json");
    EXPECT_NO_THROW(check_dataset_files(set));
    EXPECT_EQ(set.name, dir().filename().string());
    ASSERT_EQ(set.models.size(), 1u);
    EXPECT_EQ(set.models[0].name, "carton");
    EXPECT_EQ(set.models[0].file, dir() / "carton.mfpcm");
    ASSERT_EQ(set.scenes.size(), 3u);
    for (std::size_t k = 0; k < set.scenes.size(); ++k) {
        const std::string name = sequence_frame_directory(std::uint32_t(k), 3);
        EXPECT_EQ(set.scenes[k].name, name);
        EXPECT_EQ(set.scenes[k].group, "sequence");
        EXPECT_EQ(set.scenes[k].cloud, dir() / name / "scene.pcd");
        EXPECT_EQ(set.scenes[k].ground_truth, dir() / name / "scene.gt.json");
        EXPECT_EQ(set.scenes[k].fovea, dir() / name / "fovea.json");
    }
}

TEST_F(SyntheticSequenceFiles, ObjectsStandStillInTheWorldAsTheCameraTurns)
{
    std::vector<Pose> world;      // frame 0's instances in the world
    std::vector<Pose> in_first;   // and in frame 0's camera frame
    double first_heading = 0;
    for (std::uint32_t k = 0; k < 3; ++k) {
        const std::filesystem::path frame = dir() / sequence_frame_directory(k, 3);
        const auto scene = nlohmann::json::parse(slurp(frame / "scene.json"));
        const Pose camera = pose_of(scene["camera_in_world"]);
        EXPECT_EQ(scene["frame"]["index"], k);
        EXPECT_EQ(scene["seed"], small_table().seed);
        EXPECT_NEAR(scene["frame"]["heading_deg"].get<double>(), 6.0 * k, 1e-9);

        const GroundTruth truth = read_ground_truth(frame / "scene.gt.json");
        EXPECT_EQ(truth.model, "../carton.pcd");
        EXPECT_TRUE(std::filesystem::exists(frame / truth.model));
        ASSERT_EQ(truth.instances.size(), 2u);
        for (std::size_t i = 0; i < truth.instances.size(); ++i) {
            const GroundTruthInstance& instance = truth.instances[i];
            EXPECT_GT(instance.visible_fraction, 0.0f) << k;
            EXPECT_LE(instance.visible_fraction, 1.0f) << k;
            EXPECT_GT(instance.visible_points, 0) << k;
            const Pose in_world = camera * instance.transform;
            if (k == 0) {
                world.push_back(in_world);
                in_first.push_back(instance.transform);
                continue;
            }
            EXPECT_LT((in_world.matrix() - world[i].matrix()).cwiseAbs().maxCoeff(), 1e-5f) << "frame " << k << " instance " << i;
            // Seen from elsewhere: the pose in the camera frame does change.
            EXPECT_GT(translation_error(instance.transform, in_first[i]), 0.005f) << "frame " << k << " instance " << i;
        }
        // The camera turned by the heading step about the vertical through the objects' centre.
        Eigen::Vector3f centre = Eigen::Vector3f::Zero();
        for (const auto& object : scene["objects"]) centre += pose_of(object["pose_in_world"]).translation();
        centre /= float(scene["objects"].size());
        centre.z() = 0.08f;
        const double heading = orbit_of(camera, centre).heading;
        if (k == 0) first_heading = heading;
        EXPECT_NEAR(wrapped(heading - first_heading), k * 6.0 * std::numbers::pi / 180.0, 1e-5) << k;
    }
}

TEST_F(SyntheticSequenceFiles, SameBytesOnARerunWithOneThread)
{
    const test::TempDir again;
    {
        const tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
        write_synthetic_sequence(again.path(), builtin_scene_shapes(), small_table(), small_sensor(), few_frames());
    }
    for (const char* file : {"frame_000/scene.pcd", "frame_001/scene.pcd", "frame_002/scene.pcd",
                             "frame_002/scene.gt.json", "frame_002/labels.png", "frame_002/scene.json",
                             "frame_002/fovea.json", "carton.pcd", "carton.mfpcm", "frames.txt"}) {
        const std::string bytes = slurp(dir() / file);
        EXPECT_FALSE(bytes.empty()) << file;
        EXPECT_EQ(bytes, slurp(again / file)) << file;
    }
    // Each frame has noise and a view of its own.
    EXPECT_NE(slurp(dir() / "frame_000/scene.pcd"), slurp(dir() / "frame_001/scene.pcd"));
}

}  // namespace
}  // namespace mfpc
