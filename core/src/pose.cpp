#include "mfpc/core/pose.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "mfpc/core/error.hpp"

namespace mfpc {

Pose pose_from_row_major(std::span<const double> values, const std::string& where)
{
    if (values.size() != 16) {
        throw Error(where, "a pose needs 16 numbers (row-major 4x4), got " + std::to_string(values.size()));
    }
    Eigen::Matrix4d m;
    for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) {
            m(r, c) = values[std::size_t(r * 4 + c)];
        }
    }
    if (!m.allFinite()) throw Error(where, "pose has a non-finite entry");
    // Converting a double beyond float range to float is undefined.
    if (m.cwiseAbs().maxCoeff() > double(std::numeric_limits<float>::max())) {
        throw Error(where, "pose has an entry beyond float range");
    }
    constexpr double tolerance = 1e-3;
    if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > tolerance) {
        throw Error(where, "last row of the pose is not (0 0 0 1)");
    }
    const Eigen::Matrix3d rotation = m.topLeftCorner<3, 3>();
    if ((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > tolerance ||
        rotation.determinant() < 0) {
        throw Error(where, "rotation block of the pose is not a rotation (orthonormal, determinant +1)");
    }
    Pose pose = Pose::Identity();
    pose.linear() = rotation.cast<float>();
    pose.translation() = m.topRightCorner<3, 1>().cast<float>();
    return pose;
}

std::array<double, 16> pose_to_row_major(const Pose& pose)
{
    std::array<double, 16> values{};
    const Eigen::Matrix4f m = pose.matrix();
    for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c) {
            values[std::size_t(r * 4 + c)] = m(r, c);
        }
    }
    return values;
}

float translation_error(const Pose& a, const Pose& b)
{
    return (a.translation() - b.translation()).norm();
}

float rotation_error_deg(const Pose& a, const Pose& b)
{
    const Eigen::Matrix3f relative = a.linear().transpose() * b.linear();
    // acos of a trace rounded just past ±1 would be NaN.
    const float cosine = std::clamp((relative.trace() - 1.0f) * 0.5f, -1.0f, 1.0f);
    return std::acos(cosine) * 180.0f / std::numbers::pi_v<float>;
}

}  // namespace mfpc
