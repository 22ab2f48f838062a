#pragma once

/// @file
/// @brief The virtual depth sensor: shapes placed in a synthetic scene, the sensor's model, and the
/// Embree scanner that images them.

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

/// @brief Something the virtual sensor can see, in its own frame (metres, z up, standing on
/// z = 0): a triangle mesh, or a point cloud with normals drawn as oriented discs (Embree's oriented
/// disc points), so a real scan can be placed in a synthetic scene.
struct SceneShape {
    std::string name;       ///< The shape's name (a built-in object's, or a file's stem).
    TriangleMesh mesh;      ///< Used when not empty.
    PointCloud discs;       ///< Points with normals, used when the mesh is empty.
    float disc_radius = 0;  ///< Metres, for discs.
    int symmetry_order = 1;  ///< About the z axis: 1 none, N turns of 360/N degrees, 0 any angle.
    /// A half-turn about the x axis through the shape's mid-height leaves it unchanged too (a box).
    bool symmetry_flip = false;
};

/// @brief The points that stand for a shape's extent (own frame): mesh vertices or disc centres.
/// @param shape The shape.
/// @return The mesh's vertices, or the disc centres when the mesh is empty.
std::span<const Eigen::Vector3f> outline(const SceneShape& shape);
/// @brief The radius of a shape's footprint around its z axis (own frame).
/// @param shape The shape.
/// @return The largest distance of its outline's points from the z axis.
float footprint_radius(const SceneShape& shape);
/// @brief The bounding box of a shape (own frame).
/// @param shape The shape.
/// @return The box of its outline's points.
Box shape_bounds(const SceneShape& shape);

/// @brief The pose of a camera at `eye` looking at `target` in a world with z up, in the sensor's
/// frame convention (x right, y down, z forward): right is level, down points towards the ground.
/// Looking straight down (or up), the world's x is taken as right.
/// @param eye The camera's position.
/// @param target The point it looks at.
/// @return Camera frame -> world frame.
Pose camera_looking_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target);

/// @brief A shape placed in the world.
struct SceneObject {
    std::size_t shape = 0;  ///< Into SyntheticScene::shapes.
    Pose pose = Pose::Identity();  ///< Object frame -> world frame.
    bool distractor = false;       ///< Not an instance of the object to recognise.
};

/// @brief A scene in a world frame with z up: an optional support plane z = 0 (a table top centred
/// at the origin) and the objects on it, seen by a camera whose frame is the sensor's (x right,
/// y down, z forward, as Kinect clouds).
struct SyntheticScene {
    std::vector<SceneShape> shapes;    ///< The shapes the objects name.
    std::vector<SceneObject> objects;  ///< The placed objects; object i has label label_first_object + i.
    Eigen::Vector2f plane_half_size{0.6f, 0.45f};  ///< Table top; zero: no plane.
    Pose camera = Pose::Identity();               ///< Camera frame -> world frame.
};

/// @brief A Kinect-like structured-light sensor.
///
/// The depth z of the surface seen through a pixel's centre becomes the disparity d = b f / z,
/// Gaussian noise is added to d (so the noise in z grows with z²: sigma_z(z) = noise_at_1m * z²),
/// d is rounded to 1/disparity_subpixel pixel, and z = b f / d. No return where the ray meets a
/// surface at more than max_incidence_deg from its normal, or the depth lies outside [min_range,
/// max_range]. The point is put back on the pixel's ray, so the organized cloud fits the pinhole
/// exactly (fit_camera recovers it).
struct SensorParams {
    std::uint32_t width = 640;    ///< Image width in pixels.
    std::uint32_t height = 480;   ///< Image height in pixels.
    float focal_length = 0;       ///< Pixels (fx = fy); 0: 525 scaled by width / 640 (the Kinect's field of view).
    float noise_at_1m = 0.0015f;  ///< Sigma of z at 1 m, metres; 0: no noise.
    float baseline = 0.075f;      ///< Metres, projector to camera.
    int disparity_subpixel = 8;   ///< Quantization steps per pixel of disparity; 0: no quantization.
    float max_incidence_deg = 80.0f;  ///< No return from a surface seen more obliquely than this (degrees).
    float min_range = 0.4f;           ///< No return nearer than this (metres) ...
    float max_range = 4.0f;           ///< ... or farther than this.

    /// @brief The sensor's pinhole.
    /// @return Its intrinsics, the principal point at the image centre.
    Camera camera() const;
};

/// @brief Checks that a sensor can work.
/// @param sensor The sensor.
/// @throws mfpc::Error naming the offending field for a sensor that cannot work (a zero or
/// oversized resolution, above 16384 a side; a focal length that is negative, not finite or so
/// short that the field of view exceeds 170 degrees; a baseline that is not positive; negative
/// noise or subpixel; an incidence outside (0, 90]; a range that is negative, empty or infinite).
void check_sensor(const SensorParams& sensor);

/// @brief The label of a scan's pixel without a return. Labels of a scan's pixels: 0 no return,
/// 1 the support plane, 2 + i object i.
inline constexpr std::uint16_t label_none = 0;
/// @brief The label of the support plane's pixels.
inline constexpr std::uint16_t label_plane = 1;
/// @brief The label of object 0's pixels; object i's is label_first_object + i.
inline constexpr std::uint16_t label_first_object = 2;

/// @brief What one scan saw.
struct Scan {
    PointCloud cloud;                   ///< Organized (width x height), camera frame; finite points only.
    std::vector<std::uint16_t> labels;  ///< width * height, row-major.
    std::vector<std::size_t> visible_points;  ///< Per object: returns that hit it.
    Camera camera;                      ///< The sensor's pinhole (SensorParams::camera()).
};

/// @brief The Embree scene of a SyntheticScene, built once and scanned many times (from other
/// sensors or seeds). Every geometry is placed in the camera frame when the scanner is built.
class VirtualScanner {
public:
    /// @brief Builds the Embree scene of `scene`.
    /// @param scene The scene; the scanner keeps no reference to it.
    /// @throws mfpc::Error for more objects than labels can number, an object naming a shape the
    /// scene lacks, a triangle with a vertex index out of range, a shape with neither a mesh nor
    /// discs with normals and a radius, or an error Embree reports while building.
    explicit VirtualScanner(const SyntheticScene& scene);
    /// @brief Releases the Embree scene.
    ~VirtualScanner();
    /// @brief Takes over another scanner's Embree scene.
    VirtualScanner(VirtualScanner&&) noexcept;
    /// @brief Takes over another scanner's Embree scene.
    /// @return This scanner.
    VirtualScanner& operator=(VirtualScanner&&) noexcept;

    /// @brief Casts one ray through every pixel centre (Embree, parallel with TBB over rows).
    ///
    /// The noise of a pixel is drawn from a generator keyed by (seed, pixel), so the scan is
    /// bit-identical for any thread count.
    /// @param sensor The sensor.
    /// @param seed Keys the sensor noise.
    /// @return The scan: the organized cloud, the pixels' labels and each object's returns.
    /// @throws mfpc::Error for a sensor check_sensor refuses.
    Scan scan(const SensorParams& sensor, std::uint32_t seed) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

/// @brief Scans a scene once: VirtualScanner(scene).scan(sensor, seed).
/// @param scene The scene.
/// @param sensor The sensor.
/// @param seed Keys the sensor noise.
/// @return The scan.
/// @throws mfpc::Error as VirtualScanner and VirtualScanner::scan.
inline Scan scan_scene(const SyntheticScene& scene, const SensorParams& sensor, std::uint32_t seed)
{
    return VirtualScanner(scene).scan(sensor, seed);
}

}  // namespace mfpc
