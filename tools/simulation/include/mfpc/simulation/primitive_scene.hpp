#pragma once

/// @file
/// @brief The built-in analytic tabletop scene (boxes, cylinders and spheres), which needs no input
/// file and no Embree.

#include <cstdint>
#include <string>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

/// @brief The parameters of a built-in tabletop scene sampled analytically.
///
/// A pinhole camera (Kinect-like intrinsics) looks down at a finite table top carrying boxes,
/// upright cylinders and spheres, and every pixel's ray is intersected exactly with those
/// primitives. The result is an organized cloud in the camera frame (x right, y down, z forward;
/// NaN pixels, where a ray misses everything, are dropped and the index map keeps each point's
/// pixel) and a foveation config with one structure around each object. It needs no input file, so
/// the quick start and the tests can run anywhere. The same seed gives the same scene with the same
/// standard library (the random distributions are libstdc++'s).
struct PrimitiveSceneParams {
    std::uint32_t seed = 1;          ///< Object placement; the same seed gives the same scene.
    std::uint32_t objects = 4;       ///< 1..8 objects on the table.
    std::uint32_t width = 640;       ///< Image width in pixels.
    std::uint32_t height = 480;      ///< Image height in pixels.
    float focal_length = 525.0f;     ///< Pixels (fx = fy).
    float depth_noise = 0.001f;      ///< Standard deviation at 1 m (metres), growing with z²; 0 = exact.
    int levels = 3;                  ///< m of the generated foveation config.
};

/// @brief One object of a primitive scene.
struct PrimitiveObject {
    std::string shape;  ///< "box", "cylinder" or "sphere".
    Box bounds;         ///< In the camera frame.
};

/// @brief A primitive scene: its cloud, its objects and a foveation config for them.
struct PrimitiveScene {
    PointCloud cloud;                      ///< The organized scan, camera frame (finite points only).
    std::vector<PrimitiveObject> objects;  ///< The objects, in placement order.
    /// One structure per object, fovea on the object: the fovea is the object's box (camera frame),
    /// the outer box that grown by 10 cm on every side; d = 2 cm .. 5 mm, r = 3 cm .. 1 cm.
    FoveationConfig fovea;
};

/// @brief Samples a built-in tabletop scene (see PrimitiveSceneParams).
/// @param params The scene.
/// @return The cloud, its objects and one foveated structure per object.
/// @throws mfpc::Error for objects outside 1..8, a resolution outside 8..8192 pixels a side, a
/// focal length that is not positive, a negative depth noise, levels < 1, or a view in which no
/// ray hits the table.
PrimitiveScene make_primitive_scene(const PrimitiveSceneParams& params = {});

}  // namespace mfpc
