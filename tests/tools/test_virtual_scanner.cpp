// The virtual scanner against geometry whose depth is known in closed form, the sensor model's
// statistics, and the ground truth and labels of composed scenes.
#include <cmath>
#include <cstring>
#include <numbers>
#include <numeric>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "mfpc/core/camera.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/simulation/mesh.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"
#include "mfpc/simulation/virtual_scanner.hpp"
#include "triangle_distance.hpp"

namespace mfpc {
namespace {

// A camera `height` above the plane looking straight down: every pixel sees the plane at depth `height`.
Pose camera_looking_down(float height)
{
    Pose pose = Pose::Identity();
    pose.linear().col(0) = Eigen::Vector3f(1, 0, 0);
    pose.linear().col(1) = Eigen::Vector3f(0, -1, 0);
    pose.linear().col(2) = Eigen::Vector3f(0, 0, -1);
    pose.translation() = Eigen::Vector3f(0, 0, height);
    return pose;
}

SensorParams exact_sensor(std::uint32_t width = 160, std::uint32_t height = 120)
{
    SensorParams sensor;
    sensor.width = width;
    sensor.height = height;
    sensor.noise_at_1m = 0;
    sensor.disparity_subpixel = 0;
    return sensor;
}

Eigen::Vector3f pixel_ray(const Camera& camera, std::uint32_t pixel)
{
    return Eigen::Vector3f((float(pixel % camera.width) - camera.cx) / camera.fx,
                           (float(pixel / camera.width) - camera.cy) / camera.fy, 1.0f);
}

TriangleMesh uv_sphere(float radius, int segments, int rings)
{
    TriangleMesh mesh;
    mesh.vertices.emplace_back(0, 0, -radius);
    for (int r = 1; r < rings; ++r) {
        const double theta = std::numbers::pi * r / rings - std::numbers::pi / 2;
        for (int s = 0; s < segments; ++s) {
            const double phi = 2 * std::numbers::pi * s / segments;
            mesh.vertices.emplace_back(float(radius * std::cos(theta) * std::cos(phi)),
                                       float(radius * std::cos(theta) * std::sin(phi)), float(radius * std::sin(theta)));
        }
    }
    mesh.vertices.emplace_back(0, 0, radius);
    auto ring_vertex = [&](int r, int s) { return 1 + (r - 1) * segments + (s % segments); };
    const int top = int(mesh.vertices.size()) - 1;
    for (int s = 0; s < segments; ++s) {
        mesh.triangles.emplace_back(0, ring_vertex(1, s + 1), ring_vertex(1, s));
        for (int r = 1; r + 1 < rings; ++r) {
            mesh.triangles.emplace_back(ring_vertex(r, s), ring_vertex(r, s + 1), ring_vertex(r + 1, s + 1));
            mesh.triangles.emplace_back(ring_vertex(r, s), ring_vertex(r + 1, s + 1), ring_vertex(r + 1, s));
        }
        mesh.triangles.emplace_back(ring_vertex(rings - 1, s), ring_vertex(rings - 1, s + 1), top);
    }
    return mesh;
}

TEST(VirtualScanner, PlaneDepthIsAnalytic)
{
    SyntheticScene scene;
    scene.plane_half_size = Eigen::Vector2f(50, 50);
    scene.camera = camera_looking_at(Eigen::Vector3f(0.2f, -1.1f, 0.9f), Eigen::Vector3f(0, 0, 0));
    const Scan scan = scan_scene(scene, exact_sensor(), 1);
    ASSERT_EQ(scan.cloud.size(), 160u * 120u);  // the plane fills the view
    const Eigen::Matrix3f rotation = scene.camera.linear();
    const Eigen::Vector3f eye = scene.camera.translation();
    double worst = 0;
    for (std::size_t i = 0; i < scan.cloud.size(); ++i) {
        const Eigen::Vector3f ray = pixel_ray(scan.camera, scan.cloud.source_index[i]);
        const double depth = -double(eye.z()) / double((rotation * ray).z());  // ray hits z = 0 at t = depth
        worst = std::max(worst, std::abs(double(scan.cloud.points[i].z()) - depth) / depth);
        EXPECT_EQ(scan.labels[scan.cloud.source_index[i]], label_plane);
    }
    EXPECT_LT(worst, 3e-6);  // float ray casting: measured 9.8e-7
}

TEST(VirtualScanner, SphereDepthIsAnalytic)
{
    const float radius = 0.15f;
    SyntheticScene scene;
    scene.plane_half_size = Eigen::Vector2f::Zero();
    scene.shapes.push_back({"sphere", uv_sphere(radius, 512, 256), {}, 0});
    SceneObject sphere;
    sphere.pose.translation() = Eigen::Vector3f(0.05f, 0.02f, 0.3f);
    scene.objects.push_back(sphere);
    scene.camera = camera_looking_at(Eigen::Vector3f(0, -0.9f, 0.6f), Eigen::Vector3f(0, 0, 0.3f));
    const Scan scan = scan_scene(scene, exact_sensor(), 1);
    ASSERT_GT(scan.cloud.size(), 1000u);
    EXPECT_EQ(scan.visible_points[0], scan.cloud.size());

    const Eigen::Vector3f centre = scene.camera.inverse() * sphere.pose.translation();
    std::size_t checked = 0;
    double worst = 0;
    for (std::size_t i = 0; i < scan.cloud.size(); ++i) {
        const Eigen::Vector3d ray = pixel_ray(scan.camera, scan.cloud.source_index[i]).cast<double>();
        // |t ray - c|² = r²: the nearer root.
        const double a = ray.squaredNorm(), b = -2 * ray.dot(centre.cast<double>());
        const double c = centre.cast<double>().squaredNorm() - double(radius) * radius;
        const double discriminant = b * b - 4 * a * c;
        ASSERT_GE(discriminant, 0) << "a return where the ray misses the sphere";
        const double depth = (-b - std::sqrt(discriminant)) / (2 * a);
        const Eigen::Vector3d hit = depth * ray;
        const double incidence = std::abs((hit - centre.cast<double>()).normalized().dot(ray.normalized()));
        if (incidence < 0.7) continue;  // near the silhouette the facets' error along the ray grows without bound
        worst = std::max(worst, std::abs(double(scan.cloud.points[i].z()) - depth));
        ++checked;
    }
    EXPECT_GT(checked, scan.cloud.size() / 2);
    // A facet of a 512 x 256 sphere lies within r (1 - cos(diagonal / 2)) = 5.6 µm of the sphere;
    // up to incidence 45° that is 8 µm along the ray, plus float rounding. Measured: 7.5 µm.
    EXPECT_LT(worst, 1.2e-5);
}

TEST(VirtualScanner, NoiseGrowsWithDepthSquared)
{
    SyntheticScene scene;
    scene.plane_half_size = Eigen::Vector2f(50, 50);
    SensorParams sensor = exact_sensor(320, 240);
    sensor.noise_at_1m = 0.0015f;
    double sigma[2];
    const float heights[2] = {1.0f, 2.0f};
    for (int h = 0; h < 2; ++h) {
        scene.camera = camera_looking_down(heights[h]);
        const Scan scan = scan_scene(scene, sensor, 7);
        ASSERT_EQ(scan.cloud.size(), 320u * 240u);
        double sum = 0, squares = 0;
        for (const Point& p : scan.cloud.points) {
            const double error = double(p.z()) - heights[h];
            sum += error;
            squares += error * error;
        }
        const double n = double(scan.cloud.size());
        sigma[h] = std::sqrt(squares / n - (sum / n) * (sum / n));
    }
    // 76,800 samples estimate sigma within 0.3%; the noise is Gaussian in disparity, so in depth it
    // is Gaussian to first order (measured: 1.50 mm and 6.00 mm).
    EXPECT_NEAR(sigma[0], 0.0015, 0.0015 * 0.02);
    EXPECT_NEAR(sigma[1], 0.0015 * 4, 0.006 * 0.02);
}

TEST(VirtualScanner, DisparityIsQuantized)
{
    SyntheticScene scene;
    scene.plane_half_size = Eigen::Vector2f(50, 50);
    scene.camera = camera_looking_down(1.003f);
    SensorParams sensor = exact_sensor();
    sensor.disparity_subpixel = 8;
    const Scan scan = scan_scene(scene, sensor, 1);
    // Disparity b f / z = 0.075 * 131.25 / 1.003 = 9.814 px (160 px wide: f = 525 / 4) rounds to
    // 79 / 8 px, which puts the plane at 0.9968 m, 6 mm nearer than it is.
    const double bf = 0.075 * scan.camera.fx;
    const float expected = float(bf / (std::round(bf / 1.003 * 8.0) / 8.0));
    EXPECT_GT(std::abs(expected - 1.003f), 0.005f);
    ASSERT_EQ(scan.cloud.size(), 160u * 120u);
    for (const Point& p : scan.cloud.points) ASSERT_NEAR(p.z(), expected, 1e-6f);
}

TEST(VirtualScanner, NoReturnAtGrazingAnglesOrOutOfRange)
{
    SyntheticScene scene;
    scene.plane_half_size = Eigen::Vector2f(50, 50);
    SensorParams sensor = exact_sensor();
    // Seen from 20° above the plane the centre ray meets it at 70° incidence.
    scene.camera = camera_looking_at(Eigen::Vector3f(0, -std::cos(0.349f), std::sin(0.349f)), Eigen::Vector3f::Zero());
    const std::size_t centre_pixel = 60 * 160 + 80;
    sensor.max_incidence_deg = 75;
    EXPECT_NE(scan_scene(scene, sensor, 1).labels[centre_pixel], label_none);
    sensor.max_incidence_deg = 65;
    EXPECT_EQ(scan_scene(scene, sensor, 1).labels[centre_pixel], label_none);

    sensor = exact_sensor();
    scene.camera = camera_looking_down(4.5f);
    EXPECT_TRUE(scan_scene(scene, sensor, 1).cloud.empty());  // beyond max_range 4 m
    scene.camera = camera_looking_down(0.3f);
    EXPECT_TRUE(scan_scene(scene, sensor, 1).cloud.empty());  // nearer than min_range 0.4 m
}

TEST(VirtualScanner, BadSensorIsAnError)
{
    SensorParams sensor;
    sensor.width = 0;
    EXPECT_THROW(check_sensor(sensor), Error);
    sensor = SensorParams{};
    sensor.baseline = -1;
    EXPECT_THROW(check_sensor(sensor), Error);
    sensor = SensorParams{};
    sensor.max_incidence_deg = 95;
    EXPECT_THROW(check_sensor(sensor), Error);
    sensor = SensorParams{};
    sensor.min_range = 5;
    EXPECT_THROW(check_sensor(sensor), Error);
    sensor = SensorParams{};
    sensor.noise_at_1m = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW(check_sensor(sensor), Error);
}

TEST(SceneComposer, ObjectsStandOnTheTableApart)
{
    for (std::uint32_t seed : {1u, 2u, 3u, 4u}) {
        ComposeParams params;
        params.seed = seed;
        params.objects = 4;
        params.distractors = 5;
        const SyntheticScene scene = compose_scene(builtin_scene_shapes(), params);
        ASSERT_EQ(scene.objects.size(), 9u);
        for (std::size_t i = 0; i < scene.objects.size(); ++i) {
            const SceneObject& a = scene.objects[i];
            EXPECT_EQ(a.distractor, i >= 4);
            EXPECT_EQ(a.shape == 0, !a.distractor);
            EXPECT_FLOAT_EQ(a.pose.translation().z(), 0.0f);
            EXPECT_NEAR((a.pose.linear() * Eigen::Vector3f::UnitZ()).z(), 1.0f, 1e-6f);  // upright
            for (std::size_t j = 0; j < i; ++j) {
                const SceneObject& b = scene.objects[j];
                const float apart = (a.pose.translation() - b.pose.translation()).norm();
                EXPECT_GE(apart, footprint_radius(scene.shapes[a.shape]) + footprint_radius(scene.shapes[b.shape]))
                    << "objects " << i << " and " << j << " interpenetrate (seed " << seed << ")";
            }
        }
        // The camera is above the table, looking down at it.
        EXPECT_GT(scene.camera.translation().z(), 0.2f);
        EXPECT_LT((scene.camera.linear() * Eigen::Vector3f::UnitZ()).z(), -0.3f);
    }
}

TEST(SceneComposer, SeedsAreReproducible)
{
    ComposeParams params;
    params.seed = 11;
    const SyntheticScene a = compose_scene(builtin_scene_shapes(), params);
    const SyntheticScene b = compose_scene(builtin_scene_shapes(), params);
    params.seed = 12;
    const SyntheticScene c = compose_scene(builtin_scene_shapes(), params);
    EXPECT_TRUE(a.camera.matrix() == b.camera.matrix());
    EXPECT_FALSE(a.camera.matrix() == c.camera.matrix());
    for (std::size_t i = 0; i < a.objects.size(); ++i) EXPECT_TRUE(a.objects[i].pose.matrix() == b.objects[i].pose.matrix());
}

TEST(SceneComposer, CrowdedTablesGrow)
{
    ComposeParams params;
    params.objects = 40;
    params.distractors = 40;
    const SyntheticScene scene = compose_scene(builtin_scene_shapes(), params);
    EXPECT_EQ(scene.objects.size(), 80u);
    EXPECT_GT(scene.plane_half_size.x(), params.placement_half_x + 0.3f);
}

TEST(SceneComposer, ContradictionsAreErrors)
{
    ComposeParams params;
    EXPECT_THROW(compose_scene({}, params), Error);
    EXPECT_THROW(compose_scene({make_builtin_shape("carton")}, params), Error);  // distractors, no distractor shape
    params.camera_distance_min = 2;
    params.camera_distance_max = 1;
    EXPECT_THROW(compose_scene(builtin_scene_shapes(), params), Error);
    params = ComposeParams{};
    params.objects = 0;
    params.distractors = 0;
    EXPECT_THROW(compose_scene(builtin_scene_shapes(), params), Error);
}

// Scans of a composed scene with the same seed are the same bytes with 1 and 2 threads.
TEST(VirtualScanner, ScansAreBitIdenticalAcrossThreadCounts)
{
    const SyntheticScene scene = compose_scene(builtin_scene_shapes(), ComposeParams{});
    const SensorParams sensor;
    Scan scans[2];
    for (int threads = 1; threads <= 2; ++threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
        scans[threads - 1] = scan_scene(scene, sensor, 5);
    }
    ASSERT_EQ(scans[0].cloud.size(), scans[1].cloud.size());
    EXPECT_EQ(0, std::memcmp(scans[0].cloud.points.data(), scans[1].cloud.points.data(),
                             scans[0].cloud.size() * sizeof(Point)));
    EXPECT_EQ(scans[0].cloud.source_index, scans[1].cloud.source_index);
    EXPECT_EQ(scans[0].labels, scans[1].labels);
    const Scan other_seed = scan_scene(scene, sensor, 6);
    EXPECT_NE(other_seed.cloud.points, scans[0].cloud.points);  // same rays, other noise
    EXPECT_EQ(other_seed.visible_points.size(), scans[0].visible_points.size());
}

// The ground truth is exact: without noise every return labelled as object i lies on object i's
// mesh placed by its transform, and the label counts are the visible points.
TEST(VirtualScanner, LabelsAndGroundTruthAgreeExactly)
{
    ComposeParams params;
    params.seed = 3;
    const SyntheticScene scene = compose_scene(builtin_scene_shapes(), params);
    const Scan scan = scan_scene(scene, exact_sensor(320, 240), 3);
    std::vector<std::size_t> counts(scene.objects.size(), 0);
    std::vector<double> worst(scene.objects.size(), 0);
    for (std::size_t i = 0; i < scan.cloud.size(); ++i) {
        const std::uint16_t label = scan.labels[scan.cloud.source_index[i]];
        ASSERT_NE(label, label_none);
        if (label == label_plane) {
            EXPECT_NEAR((scene.camera * scan.cloud.points[i]).z(), 0.0f, 1e-5f);
            continue;
        }
        const std::size_t object = label - label_first_object;
        ++counts[object];
        const Eigen::Vector3f local = (scene.camera.inverse() * scene.objects[object].pose).inverse() * scan.cloud.points[i];
        worst[object] = std::max(worst[object], test::distance_to_mesh(scene.shapes[scene.objects[object].shape].mesh, local));
    }
    EXPECT_EQ(counts, scan.visible_points);
    for (std::size_t object = 0; object < scene.objects.size(); ++object) {
        EXPECT_GT(counts[object], 0u) << "object " << object << " is hidden";
        EXPECT_LT(worst[object], 2e-6) << "object " << object;  // float casting at ~1 m; measured 0.2 µm
    }
}

// With the default Kinect-like sensor, the visible part of each instance's model cloud, moved by
// the ground-truth transform, lies on the scan within the sensor's noise.
TEST(VirtualScanner, GroundTruthPutsTheModelOnTheScan)
{
    ComposeParams params;
    params.seed = 8;
    const SensorParams sensor;
    const SyntheticDataset dataset = make_synthetic_dataset(builtin_scene_shapes(), params, sensor);
    const SyntheticScene& scene = dataset.scene;
    const Scan& scan = dataset.scan;
    const NeighborGrid grid(scan.cloud.points, 0.01f);
    // The index of each pixel's point, to compare a model point with the return of its own pixel.
    std::vector<std::int64_t> point_of_pixel(scan.labels.size(), -1);
    for (std::size_t i = 0; i < scan.cloud.size(); ++i) point_of_pixel[scan.cloud.source_index[i]] = std::int64_t(i);

    for (std::size_t object = 0; object < scene.objects.size(); ++object) {
        if (scene.objects[object].distractor) continue;
        const Pose transform = scene.camera.inverse() * scene.objects[object].pose;
        const PointCloud& model = dataset.models[scene.objects[object].shape];
        double sum = 0;
        std::size_t visible = 0;
        double depth_sum = 0;
        for (std::size_t p = 0; p < model.size(); ++p) {
            const Point q = transform * model.points[p];
            const Point n = transform.linear() * model.normals[p];
            if (n.dot(q) >= 0) continue;  // faces away from the sensor
            const int u = int(std::lround(scan.camera.fx * q.x() / q.z() + scan.camera.cx));
            const int v = int(std::lround(scan.camera.fy * q.y() / q.z() + scan.camera.cy));
            if (u < 0 || v < 0 || u >= int(sensor.width) || v >= int(sensor.height)) continue;
            const std::size_t pixel = std::size_t(v) * sensor.width + std::size_t(u);
            // Visible: its pixel sees this object, and not another part of it in front (the fin
            // hides some of the roof): the return is within 1 cm, several times the noise.
            if (scan.labels[pixel] != label_first_object + object) continue;
            if (q.z() > scan.cloud.points[std::size_t(point_of_pixel[pixel])].z() + 0.01f) continue;
            std::uint32_t nearest;
            float squared;
            ASSERT_TRUE(grid.nearest(q, 0.05f, nearest, squared));
            sum += std::sqrt(double(squared));
            depth_sum += q.z();
            ++visible;
        }
        ASSERT_GT(visible, 100u) << "object " << object;
        // The noise level at the object's depth: sigma_z plus half a disparity step (2.4 to 3.6 mm
        // for seed 8's cartons at 0.88 to 1.07 m; measured mean distances 1.2 to 1.6 mm).
        const double depth = depth_sum / double(visible);
        const double noise = sensor.noise_at_1m * depth * depth +
                             0.5 * depth * depth / (sensor.baseline * scan.camera.fx * sensor.disparity_subpixel);
        EXPECT_LT(sum / double(visible), noise) << "object " << object << " at " << depth << " m";
    }
}

TEST(VirtualScanner, CloudModelsAreDrawnAsDiscs)
{
    // A carton's surface sample without normals, as a scanned model would come.
    PointCloud cloud = sample_surface(make_builtin_object("carton"), 0.003f, 2);
    cloud.normals.clear();
    // Rotate it into a Kinect-like frame (y down) to exercise the up axis.
    const Eigen::Matrix3f to_kinect = Eigen::AngleAxisf(float(std::numbers::pi / 2), Eigen::Vector3f::UnitX()).toRotationMatrix();
    for (Point& p : cloud.points) p = to_kinect * p;
    const SceneShape shape = make_cloud_shape(cloud, "scanned", to_kinect * Eigen::Vector3f::UnitZ());
    EXPECT_GT(shape.disc_radius, 0.001f);
    EXPECT_LT(shape.disc_radius, 0.003f);
    const Box bounds = bounding_box(shape.discs.points);
    EXPECT_NEAR(bounds.min.z(), 0.0f, 1e-6f);
    EXPECT_NEAR(bounds.center().x(), 0.0f, 1e-5f);
    EXPECT_GT(bounds.size().z(), 0.2f);  // upright again

    SyntheticScene scene;
    scene.shapes = {shape};
    scene.objects.push_back(SceneObject{});
    scene.camera = camera_looking_at(Eigen::Vector3f(0.3f, -0.8f, 0.5f), Eigen::Vector3f(0, 0, 0.1f));
    const Scan scan = scan_scene(scene, exact_sensor(320, 240), 1);
    ASSERT_GT(scan.visible_points[0], 1000u);
    // The discs leave no holes: the sensor sees about as many points as on the carton's mesh
    // (measured: DISC_RATIO).
    SyntheticScene mesh_scene = scene;
    mesh_scene.shapes = {make_builtin_shape("carton")};
    const Scan mesh_scan = scan_scene(mesh_scene, exact_sensor(320, 240), 1);
    const double ratio = double(scan.visible_points[0]) / double(mesh_scan.visible_points[0]);
    std::printf("disc/mesh visible ratio %.4f\n", ratio);
    EXPECT_NEAR(ratio, 1.0, 0.05);
    // Every return lies within a disc radius of the cloud's surface.
    const NeighborGrid grid(shape.discs.points, 0.01f);
    for (std::size_t i = 0; i < scan.cloud.size(); ++i) {
        if (scan.labels[scan.cloud.source_index[i]] != label_first_object) continue;
        std::uint32_t nearest;
        float squared;
        ASSERT_TRUE(grid.nearest(scene.camera * scan.cloud.points[i], 0.05f, nearest, squared));
        EXPECT_LE(std::sqrt(squared), shape.disc_radius * 1.01f);
    }
}

}  // namespace
}  // namespace mfpc
