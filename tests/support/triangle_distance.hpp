#pragma once

// Exact point-to-mesh distance for the tests of the virtual scanner (brute force over triangles).
#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "mfpc/simulation/mesh.hpp"

namespace mfpc::test {

inline double distance_to_segment(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
    const Eigen::Vector3d ab = b - a;
    const double length2 = ab.squaredNorm();
    const double t = length2 > 0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
    return (a + t * ab - p).norm();
}

// The foot of the perpendicular when it falls inside the triangle (all three edge tests agree with
// the normal), else the nearest of the three edges.
inline double distance_to_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                   const Eigen::Vector3d& c)
{
    const Eigen::Vector3d normal = (b - a).cross(c - a);
    const double area2 = normal.squaredNorm();
    if (area2 > 0) {
        const Eigen::Vector3d foot = p - normal * ((p - a).dot(normal) / area2);
        const bool inside = (b - a).cross(foot - a).dot(normal) >= 0 && (c - b).cross(foot - b).dot(normal) >= 0 &&
                            (a - c).cross(foot - c).dot(normal) >= 0;
        if (inside) return (p - foot).norm();
    }
    return std::min({distance_to_segment(p, a, b), distance_to_segment(p, b, c), distance_to_segment(p, c, a)});
}

inline double distance_to_mesh(const TriangleMesh& mesh, const Eigen::Vector3f& p)
{
    const Eigen::Vector3d q = p.cast<double>();
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3i& t : mesh.triangles) {
        best = std::min(best, distance_to_triangle(q, mesh.vertices[std::size_t(t[0])].cast<double>(),
                                                   mesh.vertices[std::size_t(t[1])].cast<double>(),
                                                   mesh.vertices[std::size_t(t[2])].cast<double>()));
    }
    return best;
}

}  // namespace mfpc::test
