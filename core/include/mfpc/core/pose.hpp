#pragma once

#include <array>
#include <span>
#include <string>

#include <Eigen/Geometry>

namespace mfpc {

// A rigid transform; in ground truth and results it maps model coordinates into scene coordinates.
using Pose = Eigen::Isometry3f;

// From 16 numbers, a row-major 4x4 matrix (the shared ground-truth format). Throws mfpc::Error
// naming `where` when the matrix is not rigid: last row not (0 0 0 1), or a rotation block that is
// not orthonormal with determinant +1 within 1e-3.
Pose pose_from_row_major(std::span<const double> values, const std::string& where = "pose");
std::array<double, 16> pose_to_row_major(const Pose& pose);

// Distance between the translations (metres) and the angle of the relative rotation (degrees).
float translation_error(const Pose& a, const Pose& b);
float rotation_error_deg(const Pose& a, const Pose& b);

}  // namespace mfpc
