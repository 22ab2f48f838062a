#pragma once

/// @file
/// @brief Axis-aligned boxes (outer boxes, foveae, voxel bounds) and the bounding box of a cloud.

#include <span>

#include <Eigen/Core>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

/// @brief An axis-aligned box. Membership is closed on both ends: a point on a face is inside.
struct Box {
    Eigen::Vector3f min = Eigen::Vector3f::Zero();  ///< The lowest corner.
    Eigen::Vector3f max = Eigen::Vector3f::Zero();  ///< The highest corner.

    /// @brief The box with lowest corner `min` and edge lengths `size`.
    /// @param min The lowest corner.
    /// @param size The edge lengths along x, y and z.
    /// @return The box from `min` to `min + size`.
    static Box from_min_size(const Eigen::Vector3f& min, const Eigen::Vector3f& size)
    {
        return {min, min + size};
    }

    /// @brief The edge lengths.
    /// @return max - min.
    Eigen::Vector3f size() const { return max - min; }
    /// @brief The centre.
    /// @return The midpoint of min and max.
    Eigen::Vector3f center() const { return 0.5f * (min + max); }
    /// @brief Whether min <= max on every axis.
    /// @return False for an invalid box, such as the bounding_box() of no points.
    bool valid() const { return (min.array() <= max.array()).all(); }

    /// @brief Whether the box holds a point (closed: a point on a face is inside).
    /// @param p The point.
    /// @return Whether `p` lies inside or on the box.
    bool contains(const Eigen::Vector3f& p) const
    {
        return p.x() >= min.x() && p.x() <= max.x() && p.y() >= min.y() && p.y() <= max.y() &&
               p.z() >= min.z() && p.z() <= max.z();
    }
    /// @brief Whether the box holds all of another box (closed: shared faces count as inside).
    /// @param other The box tested.
    /// @return Whether `other` lies wholly inside this box.
    bool contains(const Box& other) const
    {
        return (other.min.array() >= min.array()).all() && (other.max.array() <= max.array()).all();
    }
    /// @brief Grows the box to hold `p` too. An invalid box (bounding_box of no points) grows to
    /// exactly that.
    /// @param p The point to hold.
    void extend(const Eigen::Vector3f& p)
    {
        min = min.cwiseMin(p);
        max = max.cwiseMax(p);
    }
    /// @brief Grows the box to hold all of `other` too. An invalid box (bounding_box of no
    /// points) grows to exactly that.
    /// @param other The box to hold.
    void extend(const Box& other)
    {
        min = min.cwiseMin(other.min);
        max = max.cwiseMax(other.max);
    }
    /// @brief Whether the two boxes share at least one point (closed: touching faces intersect).
    /// @param other The other box.
    /// @return Whether the boxes overlap or touch.
    bool intersects(const Box& other) const
    {
        return (other.min.array() <= max.array()).all() && (other.max.array() >= min.array()).all();
    }
};

/// @brief The smallest box holding every point; an empty span gives an invalid box (min > max).
/// @param points The points to bound.
/// @return Their bounding box; for no points, min = +inf and max = -inf, which extend() grows to
/// the first point or box.
Box bounding_box(std::span<const Point> points);

}  // namespace mfpc
