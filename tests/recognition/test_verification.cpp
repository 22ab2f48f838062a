#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "mfpc/core/camera.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/core/pose.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/recognition/verification.hpp"

namespace mfpc {
namespace {

// The faces of a 6 x 10 x 4 cm box centred on the origin, every 4 mm, with outward normals.
struct Box {
    std::vector<Point> points, normals;
};
Box box_model()
{
    const Eigen::Vector3f half(0.03f, 0.05f, 0.02f);
    constexpr float step = 0.004f;
    Box box;
    for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        for (const float side : {-1.0f, 1.0f})
            for (float a = -half[u]; a <= half[u] + 1e-6f; a += step)
                for (float b = -half[v]; b <= half[v] + 1e-6f; b += step) {
                    Point p;
                    p[axis] = side * half[axis];
                    p[u] = a;
                    p[v] = b;
                    Point n = Point::Zero();
                    n[axis] = side;
                    box.points.push_back(p);
                    box.normals.push_back(n);
                }
    }
    return box;
}

Pose pose_at(const Eigen::Vector3f& translation, float degrees_about_y = 0.0f)
{
    Pose pose = Pose::Identity();
    pose.linear() = Eigen::AngleAxisf(degrees_about_y * float(M_PI) / 180.0f, Eigen::Vector3f::UnitY()).toRotationMatrix();
    pose.translation() = translation;
    return pose;
}

Instance hypothesis(const Pose& pose, float votes)
{
    Instance instance;
    instance.transform = pose;
    instance.votes = votes;
    return instance;
}

// Two boxes in front of the sensor, and hypotheses as Hough voting gives them, most votes first:
// each box found twice, a little off (less than half the 4 mm sampling: point-to-point ICP on two
// copies of one lattice has a minimum at every lattice step), and one pose in empty space. Each
// box comes out once, refined onto its true pose; the second hypothesis of a box, which starts on
// the first one's place, is the same object and is dropped; the one in empty space is rejected.
// The same bits at one thread and two.
TEST(RefineAndVerify, KeepsEachObjectOnceAndRejectsEmptySpace)
{
    const Box model = box_model();
    const Pose first = pose_at({-0.1f, 0.05f, 0.8f}, 20.0f);
    const Pose second = pose_at({0.2f, 0.0f, 0.9f}, -30.0f);
    PointCloud scene;
    for (const Pose& pose : {first, second})
        for (const Point& p : model.points) scene.points.push_back(pose * p);
    scene.width = std::uint32_t(scene.points.size());
    const NeighborGrid grid(scene.points, 0.005f);
    const SceneEvidence evidence = make_scene_evidence(scene, grid, std::nullopt);

    std::vector<Instance> hypotheses = {
        hypothesis(first * pose_at({0.0015f, -0.001f, 0.0005f}, 1.0f), 40.0f),
        hypothesis(second * pose_at({-0.001f, 0.0015f, 0.0f}, -1.0f), 30.0f),
        hypothesis(first * pose_at({-0.001f, 0.001f, -0.0015f}, -1.5f), 20.0f),
        hypothesis(pose_at({0.0f, -0.4f, 1.5f}), 10.0f),
        hypothesis(second * pose_at({0.001f, 0.0f, 0.0015f}, 0.5f), 5.0f),
    };
    const std::vector<Instance> found =
        refine_and_verify(hypotheses, model.points, model.normals, evidence, RefineParams{}, VerifyParams{});
    ASSERT_EQ(found.size(), 2u);
    for (const auto& [instance, truth] : {std::pair{found[0], first}, std::pair{found[1], second}}) {
        EXPECT_LT((instance.transform.translation() - truth.translation()).norm(), 2e-4f);
        EXPECT_LT(rotation_error_deg(instance.transform, truth), 0.1f);
        EXPECT_FLOAT_EQ(instance.fitness, 1.0f);
        EXPECT_GT(instance.coverage, 0.99f);
    }
    EXPECT_EQ(found[0].votes, 40.0f);  // the first hypothesis of each box is the one kept
    EXPECT_EQ(found[1].votes, 30.0f);

    {
        tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
        const std::vector<Instance> serial =
            refine_and_verify(hypotheses, model.points, model.normals, evidence, RefineParams{}, VerifyParams{});
        ASSERT_EQ(serial.size(), found.size());
        for (std::size_t i = 0; i < found.size(); ++i) {
            EXPECT_TRUE(serial[i].transform.matrix() == found[i].transform.matrix()) << i;
            EXPECT_EQ(serial[i].fitness, found[i].fitness) << i;
        }
    }

    // Without merging, every hypothesis of a box is refined and kept.
    VerifyParams no_merge;
    no_merge.merge = false;
    EXPECT_EQ(refine_and_verify(hypotheses, model.points, model.normals, evidence, RefineParams{}, no_merge).size(), 4u);
}

// A poor fit with the most votes must not hide the true pose of its object: a box slid 12 mm along
// its long side (not refined, so it stays there) still explains most of the box and is accepted,
// but not settled, so the true pose behind it is still verified, and wins the merge.
TEST(RefineAndVerify, APoorFitDoesNotHideTheTruePose)
{
    const Box model = box_model();
    const Pose truth = pose_at({0.0f, 0.0f, 0.8f}, 25.0f);
    PointCloud scene;
    for (const Point& p : model.points) scene.points.push_back(truth * p);
    scene.width = std::uint32_t(scene.points.size());
    const NeighborGrid grid(scene.points, 0.005f);
    const SceneEvidence evidence = make_scene_evidence(scene, grid, std::nullopt);

    const Pose slid = truth * pose_at({0.0f, 0.012f, 0.0f});
    const std::vector<Instance> hypotheses = {hypothesis(slid, 50.0f), hypothesis(truth, 10.0f)};
    RefineParams no_icp;
    no_icp.enabled = false;
    // The rim probes see the box go on 3 mm past the slid pose's end and would reject it alone
    // (the next test): off, so that it passes, the case this test is about.
    VerifyParams verify;
    verify.max_continuation = 1.0f;
    const std::vector<Instance> found = refine_and_verify(hypotheses, model.points, model.normals, evidence, no_icp, verify);
    ASSERT_EQ(found.size(), 1u);
    EXPECT_EQ(found[0].votes, 10.0f);
    EXPECT_FLOAT_EQ(found[0].fitness, 1.0f);

    // The slid pose alone passes verification, with a fitness below a settled one's.
    const std::vector<Instance> alone =
        refine_and_verify({hypotheses[0]}, model.points, model.normals, evidence, no_icp, verify);
    ASSERT_EQ(alone.size(), 1u);
    EXPECT_LT(alone[0].fitness, 0.99f);
}

// The box as a sensor sees it: each pixel of a 640 x 480 Kinect-like camera keeps the nearest of
// its faces' points (sampled every millimetre), an organized scene with its camera.
PointCloud scan(const Pose& pose, const Camera& camera)
{
    const Eigen::Vector3f half(0.03f, 0.05f, 0.02f);
    std::vector<float> depth(std::size_t(camera.width) * camera.height, std::numeric_limits<float>::infinity());
    std::vector<Point> at(depth.size());
    for (int axis = 0; axis < 3; ++axis) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        for (const float side : {-1.0f, 1.0f})
            for (float a = -half[u]; a <= half[u] + 1e-6f; a += 0.001f)
                for (float b = -half[v]; b <= half[v] + 1e-6f; b += 0.001f) {
                    Point p;
                    p[axis] = side * half[axis];
                    p[u] = a;
                    p[v] = b;
                    const Point q = pose * p;
                    const long x = std::lround(camera.fx * q.x() / q.z() + camera.cx);
                    const long y = std::lround(camera.fy * q.y() / q.z() + camera.cy);
                    if (x < 0 || y < 0 || x >= long(camera.width) || y >= long(camera.height)) continue;
                    const std::size_t pixel = std::size_t(y) * camera.width + std::size_t(x);
                    if (q.z() < depth[pixel]) {
                        depth[pixel] = q.z();
                        at[pixel] = q;
                    }
                }
    }
    PointCloud cloud;
    cloud.width = camera.width;
    cloud.height = camera.height;
    for (std::size_t pixel = 0; pixel < depth.size(); ++pixel)
        if (std::isfinite(depth[pixel])) {
            cloud.points.push_back(at[pixel]);
            cloud.source_index.push_back(std::uint32_t(pixel));
        }
    return cloud;
}

// A pose slid along its object's face explains the part of the object it covers and leaves the
// rest just past its edges: the rim probes find the box going on beyond the slid pose's end, and
// reject it. At the true pose the sensor sees past every probe: the box ends where the model does.
// With a camera (the probes the sensor saw past are free) and without (those with no scene point).
TEST(RefineAndVerify, APoseSlidAlongItsObjectIsRejectedByWhatGoesOnPastIt)
{
    const Box model = box_model();
    const Pose truth = pose_at({0.0f, 0.0f, 0.8f}, 25.0f) * Pose(Eigen::AngleAxisf(0.5f, Eigen::Vector3f::UnitX()));
    const Camera camera;
    const PointCloud scene = scan(truth, camera);
    ASSERT_GT(scene.size(), 2000u);
    const NeighborGrid grid(scene.points, 0.005f);
    const Pose slid = truth * pose_at({0.0f, 0.025f, 0.0f});
    RefineParams no_icp;
    no_icp.enabled = false;
    VerifyParams off;
    off.max_continuation = 1.0f;
    for (const bool with_camera : {true, false}) {
        SCOPED_TRACE(with_camera ? "camera" : "no camera");
        const SceneEvidence evidence =
            make_scene_evidence(scene, grid, with_camera ? std::optional<Camera>(camera) : std::nullopt);
        const std::vector<Instance> at_truth =
            refine_and_verify({hypothesis(truth, 10.0f)}, model.points, model.normals, evidence, no_icp, VerifyParams{});
        ASSERT_EQ(at_truth.size(), 1u);
        EXPECT_EQ(at_truth[0].continuation, 0.0f);
        EXPECT_TRUE(
            refine_and_verify({hypothesis(slid, 10.0f)}, model.points, model.normals, evidence, no_icp, VerifyParams{})
                .empty());
        // The other tests pass it: only the rim probes see that the box goes on.
        const std::vector<Instance> slid_passes =
            refine_and_verify({hypothesis(slid, 10.0f)}, model.points, model.normals, evidence, no_icp, off);
        ASSERT_EQ(slid_passes.size(), 1u);
        EXPECT_GT(slid_passes[0].continuation, VerifyParams{}.max_continuation);
    }
}

}  // namespace
}  // namespace mfpc
