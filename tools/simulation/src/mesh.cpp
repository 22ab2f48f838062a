#include "mfpc/simulation/mesh.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <random>
#include <string>
#include <unordered_set>

#include <Eigen/Geometry>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

// Random draws per voxel-sized patch of surface before thinning: with 4, a voxel that a face fills
// is left empty with probability e^-4 (under 2 %), and the sampling stays cheap.
constexpr double oversampling = 4.0;

// Sampling a finer spacing than this would need more memory than a scanner model is worth; the
// limit turns a unit mistake (spacing in millimetres for a mesh in metres) into a clear error.
constexpr double max_samples = 5.0e7;

// Voxel coordinates are packed 21 bits an axis into one 64-bit key.
constexpr int key_bits = 21;
constexpr std::int64_t max_cells_per_axis = std::int64_t(1) << key_bits;

using Vec = Eigen::Vector3d;

Vec corner(const TriangleMesh& mesh, const Eigen::Vector3i& triangle, int k)
{
    return mesh.vertices[static_cast<std::size_t>(triangle[k])].cast<double>();
}

double triangle_area(const TriangleMesh& mesh, const Eigen::Vector3i& triangle)
{
    const Vec a = corner(mesh, triangle, 0);
    return 0.5 * (corner(mesh, triangle, 1) - a).cross(corner(mesh, triangle, 2) - a).norm();
}

// A uniform number in [0, 1) from one draw, written out rather than taken from
// std::uniform_real_distribution so that the same seed gives the same cloud with any standard library.
double unit_draw(std::mt19937& random)
{
    return static_cast<double>(random()) * 0x1.0p-32;
}

// Triangles are indexed by int in a std::vector: a bad index would read out of bounds.
void check_mesh(const TriangleMesh& mesh)
{
    if (mesh.empty()) throw Error("mesh", "has no triangles");
    const auto vertex_count = static_cast<std::int64_t>(mesh.vertices.size());
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        for (int k = 0; k < 3; ++k) {
            const int index = mesh.triangles[t][k];
            if (index < 0 || index >= vertex_count) {
                throw Error("mesh", "triangle " + std::to_string(t) + " names vertex " + std::to_string(index) +
                                        " (" + std::to_string(vertex_count) + " vertices)");
            }
        }
    }
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
        if (!within_coordinate_range(mesh.vertices[v])) {
            throw Error("mesh", "vertex " + std::to_string(v) + " is not finite or lies beyond ±" +
                                    max_coordinate_text + ", the supported range");
        }
    }
}

}  // namespace

double TriangleMesh::area() const
{
    double sum = 0.0;
    for (const Eigen::Vector3i& triangle : triangles) sum += triangle_area(*this, triangle);
    return sum;
}

Box TriangleMesh::bounds() const
{
    return bounding_box(vertices);
}

PointCloud sample_surface(const TriangleMesh& mesh, float spacing, std::uint32_t seed)
{
    if (!std::isfinite(spacing) || spacing <= 0.0f) {
        throw Error("spacing", "must be a positive finite length, got " + format_number(spacing));
    }
    check_mesh(mesh);

    // Cumulative areas pick a triangle with probability proportional to its area; a triangle of
    // zero area owns an empty interval and is never picked.
    std::vector<double> cumulative(mesh.triangles.size());
    double total = 0.0;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        total += triangle_area(mesh, mesh.triangles[t]);
        cumulative[t] = total;
    }
    if (!(total > 0.0)) throw Error("mesh", "has no area (every triangle is degenerate)");
    const double cell = spacing;
    const double wanted = std::ceil(oversampling * total / (cell * cell));
    if (wanted > max_samples) {
        throw Error("spacing", format_number(spacing) + " is too fine for a mesh of " + format_number(total) +
                                   " square units (would draw " + format_number(wanted) + " samples)");
    }

    // The grid starts half a cell below the mesh's lower corner, so that the flat faces found on
    // many objects (the bottom at z = 0, sides at whole multiples of a round spacing) run through the
    // middle of a layer of cells instead of along a cell boundary, where rounding would scatter
    // their samples over two layers and double their count.
    const Box box = mesh.bounds();
    const Vec origin = box.min.cast<double>() - Vec::Constant(0.5 * cell);
    for (int axis = 0; axis < 3; ++axis) {
        const double cells = std::floor((double(box.max[axis]) - origin[axis]) / cell) + 1.0;
        if (cells > double(max_cells_per_axis)) {
            throw Error("spacing", format_number(spacing) + " is too fine for a mesh " +
                                       format_number(box.size()[axis]) + " long (more than 2^21 cells an axis)");
        }
    }

    const auto sample_count = static_cast<std::size_t>(wanted);
    std::mt19937 random(seed);
    std::unordered_set<std::uint64_t> taken;
    taken.reserve(static_cast<std::size_t>(wanted / oversampling));  // about the count kept
    PointCloud cloud;
    for (std::size_t s = 0; s < sample_count; ++s) {
        const double pick = unit_draw(random) * total;
        const auto found = std::upper_bound(cumulative.begin(), cumulative.end(), pick);
        const auto t = static_cast<std::size_t>(
            std::min<std::ptrdiff_t>(found - cumulative.begin(), std::ptrdiff_t(cumulative.size()) - 1));
        double u = unit_draw(random);
        double v = unit_draw(random);
        // (u, v) is uniform on the unit square; folding the far half onto the near one makes it
        // uniform on the triangle u + v <= 1.
        if (u + v > 1.0) {
            u = 1.0 - u;
            v = 1.0 - v;
        }
        const Eigen::Vector3i& triangle = mesh.triangles[t];
        const Vec a = corner(mesh, triangle, 0);
        const Vec ab = corner(mesh, triangle, 1) - a;
        const Vec ac = corner(mesh, triangle, 2) - a;
        const Point point = (a + u * ab + v * ac).cast<float>();

        // The key comes from the point as stored, so that anyone can check the one-per-voxel rule.
        std::uint64_t key = 0;
        for (int axis = 0; axis < 3; ++axis) {
            const double index = std::floor((double(point[axis]) - origin[axis]) / cell);
            const auto clamped = static_cast<std::uint64_t>(std::clamp(index, 0.0, double(max_cells_per_axis - 1)));
            key = (key << key_bits) | clamped;
        }
        if (!taken.insert(key).second) continue;
        cloud.points.push_back(point);
        cloud.normals.push_back(ab.cross(ac).normalized().cast<float>());
    }
    cloud.width = static_cast<std::uint32_t>(cloud.points.size());
    cloud.height = 1;
    return cloud;
}

}  // namespace mfpc
