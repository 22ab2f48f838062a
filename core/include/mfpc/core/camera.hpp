#pragma once

#include <cstdint>
#include <optional>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

// A pinhole camera at the origin looking down +z: pixel (u, v) = (fx x / z + cx, fy y / z + cy),
// pixel centres at integer (u, v).
struct Camera {
    float fx = 525.0f;
    float fy = 525.0f;
    float cx = 319.5f;
    float cy = 239.5f;
    std::uint32_t width = 640;
    std::uint32_t height = 480;
    // Largest distance (pixels, per axis) between a point's projection and its pixel in the cloud
    // the camera was fitted to.
    float max_residual = 0.0f;
};

// The camera of an organized cloud, fitted by least squares from its points and their pixels;
// nothing for an unorganized cloud, one with a point at z <= 0, or one whose points do not fit a
// pinhole (rms residual over 1 pixel).
std::optional<Camera> fit_camera(const PointCloud& organized);

}  // namespace mfpc
