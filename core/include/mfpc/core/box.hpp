#pragma once

#include <span>

#include <Eigen/Core>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

// An axis-aligned box. Membership is closed on both ends: a point on a face is inside.
struct Box {
    Eigen::Vector3f min = Eigen::Vector3f::Zero();
    Eigen::Vector3f max = Eigen::Vector3f::Zero();

    static Box from_min_size(const Eigen::Vector3f& min, const Eigen::Vector3f& size)
    {
        return {min, min + size};
    }

    Eigen::Vector3f size() const { return max - min; }
    Eigen::Vector3f center() const { return 0.5f * (min + max); }
    bool valid() const { return (min.array() <= max.array()).all(); }

    bool contains(const Eigen::Vector3f& p) const
    {
        return p.x() >= min.x() && p.x() <= max.x() && p.y() >= min.y() && p.y() <= max.y() &&
               p.z() >= min.z() && p.z() <= max.z();
    }
    bool contains(const Box& other) const
    {
        return (other.min.array() >= min.array()).all() && (other.max.array() <= max.array()).all();
    }
    // Grows the box to hold `p` (or all of `other`) too. An invalid box (bounding_box of no points)
    // grows to exactly that.
    void extend(const Eigen::Vector3f& p)
    {
        min = min.cwiseMin(p);
        max = max.cwiseMax(p);
    }
    void extend(const Box& other)
    {
        min = min.cwiseMin(other.min);
        max = max.cwiseMax(other.max);
    }
    bool intersects(const Box& other) const
    {
        return (other.min.array() <= max.array()).all() && (other.max.array() >= min.array()).all();
    }
};

// The smallest box holding every point; an empty span gives an invalid box (min > max).
Box bounding_box(std::span<const Point> points);

}  // namespace mfpc
