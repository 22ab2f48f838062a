#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

// A built-in tabletop scene sampled analytically: a pinhole camera (Kinect-like intrinsics) looks
// down at a finite table top carrying boxes, upright cylinders and spheres, and every pixel's ray is
// intersected exactly with those primitives. The result is an organized cloud in the camera frame
// (x right, y down, z forward; NaN pixels, where a ray misses everything, are dropped and the index
// map keeps each point's pixel) and a foveation config with one structure around each object.
// It needs no input file, so the quick start and the tests can run anywhere. The same seed gives the
// same scene with the same standard library (the random distributions are libstdc++'s).
struct PrimitiveSceneParams {
    std::uint32_t seed = 1;          // object placement; the same seed gives the same scene
    std::uint32_t objects = 4;       // 1..8 objects on the table
    std::uint32_t width = 640;       // image size in pixels
    std::uint32_t height = 480;
    float focal_length = 525.0f;     // pixels (fx = fy)
    float depth_noise = 0.001f;      // standard deviation at 1 m (metres), growing with z²; 0 = exact
    int levels = 3;                  // m of the generated foveation config
};

struct PrimitiveObject {
    std::string shape;  // "box", "cylinder" or "sphere"
    Box bounds;         // in the camera frame
};

struct PrimitiveScene {
    PointCloud cloud;
    std::vector<PrimitiveObject> objects;
    FoveationConfig fovea;  // one structure per object, fovea on the object
};

PrimitiveScene make_primitive_scene(const PrimitiveSceneParams& params = {});

}  // namespace mfpc
