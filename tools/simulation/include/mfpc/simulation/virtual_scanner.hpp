#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "mfpc/core/box.hpp"
#include "mfpc/core/camera.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/core/pose.hpp"
#include "mfpc/simulation/mesh.hpp"

namespace mfpc {

// Something the virtual sensor can see, in its own frame (metres, z up, standing on z = 0): a
// triangle mesh, or a point cloud with normals drawn as oriented discs (Embree's oriented disc
// points), so a real scan can be placed in a synthetic scene.
struct SceneShape {
    std::string name;
    TriangleMesh mesh;      // used when not empty
    PointCloud discs;       // points with normals, used when the mesh is empty
    float disc_radius = 0;  // metres, for discs
    int symmetry_order = 1;  // about the z axis: 1 none, N turns of 360/N degrees, 0 any angle
};

// The points that stand for a shape's extent (own frame): mesh vertices or disc centres.
std::span<const Eigen::Vector3f> outline(const SceneShape& shape);
// The radius of a shape's footprint around its z axis, and its bounding box (own frame).
float footprint_radius(const SceneShape& shape);
Box shape_bounds(const SceneShape& shape);

// The pose of a camera at `eye` looking at `target` in a world with z up, in the sensor's frame
// convention (x right, y down, z forward): right is level, down points towards the ground.
Pose camera_looking_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target);

// A shape placed in the world.
struct SceneObject {
    std::size_t shape = 0;  // into SyntheticScene::shapes
    Pose pose = Pose::Identity();  // object frame -> world frame
    bool distractor = false;
};

// A scene in a world frame with z up: an optional support plane z = 0 (a table top centred at the
// origin) and the objects on it, seen by a camera whose frame is the sensor's (x right, y down,
// z forward, as Kinect clouds).
struct SyntheticScene {
    std::vector<SceneShape> shapes;
    std::vector<SceneObject> objects;
    Eigen::Vector2f plane_half_size{0.6f, 0.45f};  // table top; zero: no plane
    Pose camera = Pose::Identity();               // camera frame -> world frame
};

// A Kinect-like structured-light sensor. The depth z of the surface seen through a pixel's centre
// becomes the disparity d = b f / z, Gaussian noise is added to d (so the noise in z grows with z²:
// sigma_z(z) = noise_at_1m * z²), d is rounded to 1/disparity_subpixel pixel, and z = b f / d.
// No return where the ray meets a surface at more than max_incidence_deg from its normal, or the
// depth lies outside [min_range, max_range]. The point is put back on the pixel's ray, so the
// organized cloud fits the pinhole exactly (fit_camera recovers it).
struct SensorParams {
    std::uint32_t width = 640;
    std::uint32_t height = 480;
    float focal_length = 0;       // pixels (fx = fy); 0: 525 scaled by width / 640 (the Kinect's field of view)
    float noise_at_1m = 0.0015f;  // sigma of z at 1 m, metres; 0: no noise
    float baseline = 0.075f;      // metres, projector to camera
    int disparity_subpixel = 8;   // quantization steps per pixel of disparity; 0: no quantization
    float max_incidence_deg = 80.0f;
    float min_range = 0.4f;
    float max_range = 4.0f;

    Camera camera() const;  // the pinhole: principal point at the image centre
};

// Throws mfpc::Error naming the offending field for a sensor that cannot work (a zero or
// oversized resolution, non-positive focal length or baseline, negative noise or subpixel, an
// incidence outside (0, 90], an empty range).
void check_sensor(const SensorParams& sensor);

// Labels of a scan's pixels: 0 no return, 1 the support plane, 2 + i object i.
inline constexpr std::uint16_t label_none = 0;
inline constexpr std::uint16_t label_plane = 1;
inline constexpr std::uint16_t label_first_object = 2;

struct Scan {
    PointCloud cloud;                   // organized (width x height), camera frame; finite points only
    std::vector<std::uint16_t> labels;  // width * height, row-major
    std::vector<std::size_t> visible_points;  // per object: returns that hit it
    Camera camera;
};

// The Embree scene of a SyntheticScene, built once and scanned many times (from other sensors or
// seeds). Every geometry is placed in the camera frame when the scanner is built.
class VirtualScanner {
public:
    explicit VirtualScanner(const SyntheticScene& scene);
    ~VirtualScanner();
    VirtualScanner(VirtualScanner&&) noexcept;
    VirtualScanner& operator=(VirtualScanner&&) noexcept;

    // Casts one ray through every pixel centre (Embree, parallel with TBB over rows). The noise of
    // a pixel is drawn from a generator keyed by (seed, pixel), so the scan is bit-identical for
    // any thread count.
    Scan scan(const SensorParams& sensor, std::uint32_t seed) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

inline Scan scan_scene(const SyntheticScene& scene, const SensorParams& sensor, std::uint32_t seed)
{
    return VirtualScanner(scene).scan(sensor, seed);
}

}  // namespace mfpc
