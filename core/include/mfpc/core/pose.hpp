#pragma once

/// @file
/// @brief Rigid poses: reading and writing them as row-major 4x4 matrices, and the distance
/// between two.

#include <array>
#include <span>
#include <string>

#include <Eigen/Geometry>

namespace mfpc {

/// @brief A rigid transform; in ground truth and results it maps model coordinates into scene
/// coordinates.
using Pose = Eigen::Isometry3f;

/// @brief The pose of 16 numbers, a row-major 4x4 matrix (the shared ground-truth format).
/// @param values The 16 numbers, row after row.
/// @param where The name of the pose, for the error.
/// @return The pose.
/// @throws mfpc::Error naming `where` when there are not 16 numbers, an entry is not finite or
/// beyond float range, or the matrix is not rigid: last row not (0 0 0 1), or a rotation block that
/// is not orthonormal with determinant +1 within 1e-3.
Pose pose_from_row_major(std::span<const double> values, const std::string& where = "pose");
/// @brief A pose as 16 numbers, its row-major 4x4 matrix (the shared ground-truth format).
/// @param pose The pose.
/// @return The matrix, row after row, as pose_from_row_major reads it.
std::array<double, 16> pose_to_row_major(const Pose& pose);

/// @brief Distance between the translations of two poses.
/// @param a One pose.
/// @param b The other.
/// @return The distance (metres).
float translation_error(const Pose& a, const Pose& b);
/// @brief The angle of the relative rotation between two poses.
/// @param a One pose.
/// @param b The other.
/// @return The angle (degrees, 0 to 180).
float rotation_error_deg(const Pose& a, const Pose& b);

}  // namespace mfpc
