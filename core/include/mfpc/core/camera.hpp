#pragma once

/// @file
/// @brief The pinhole camera of an organized cloud, fitted from its points and pixels.

#include <cstdint>
#include <optional>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

/// @brief A pinhole camera at the origin looking down +z: pixel (u, v) = (fx x / z + cx, fy y / z
/// + cy), pixel centres at integer (u, v).
struct Camera {
    float fx = 525.0f;           ///< Focal length along u (pixels).
    float fy = 525.0f;           ///< Focal length along v (pixels).
    float cx = 319.5f;           ///< Principal point, u (pixels).
    float cy = 239.5f;           ///< Principal point, v (pixels).
    std::uint32_t width = 640;   ///< Image width (pixels).
    std::uint32_t height = 480;  ///< Image height (pixels).
    /// Largest distance (pixels, per axis) between a point's projection and its pixel in the cloud
    /// the camera was fitted to.
    float max_residual = 0.0f;
};

/// @brief The camera of an organized cloud, fitted by least squares from its points and their
/// pixels.
/// @param organized The cloud, its pixels given by its source positions on its width x height grid.
/// @return The fitted camera; nothing for an unorganized cloud, one of fewer than 100 points, one
/// with a point at z <= 0, or one whose points do not fit a pinhole (rms residual over 1 pixel).
std::optional<Camera> fit_camera(const PointCloud& organized);

}  // namespace mfpc
