#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "mfpc/core/box.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

// A triangle mesh in metres. Triangles wind counter-clockwise seen from outside, so the right-hand
// normal of each points out of the object.
struct TriangleMesh {
    std::vector<Eigen::Vector3f> vertices;
    std::vector<Eigen::Vector3i> triangles;

    bool empty() const noexcept { return triangles.empty(); }
    double area() const;
    Box bounds() const;
};

// The built-in household objects of the virtual scanner, each in its own frame: metres, z up,
// standing on the plane z = 0, its footprint centred on the z axis.
//   carton  gable-top milk carton (box body, two roof slopes, gables and the top fin)
//   bottle  surface of revolution: body, shoulder, neck and cap
//   mug     open cylinder shell with a floor and a handle
//   box     a cracker box (shallower than the carton is wide)
//   jug     detergent-style jug: rounded body, shoulder, cap and a handle
std::span<const std::string_view> builtin_object_names();
bool is_builtin_object(std::string_view name);
// Throws mfpc::Error naming the object for an unknown name.
TriangleMesh make_builtin_object(std::string_view name);
// The order of the object's rotational symmetry about its z axis: turning it by 360/N degrees
// leaves the mesh unchanged (carton and box 2, the bottle any angle: 0, mug and jug none: 1).
int builtin_object_symmetry(std::string_view name);

// Reads a mesh from .ply (ascii or binary little/big endian; vertex x, y, z as float or double;
// faces as a list of vertex indices) or .obj (v and f records; polygons are fanned into triangles;
// f indices may be negative or carry /vt/vn parts). The extension decides the format, in any case.
// Only geometry is kept: other vertex properties, other elements and other OBJ records are skipped.
// An OBJ face may name only vertices defined above it (as every exporter writes them). Malformed
// input (bad header, truncated data, an index out of range, a face with fewer than three vertices,
// non-finite coordinates, no faces) throws mfpc::Error whose where() is the file, or "file:line"
// for .obj and ascii .ply.
TriangleMesh read_mesh(const std::filesystem::path& path);

// Points sampled on the surface with their outward normals (each point's triangle's normal), about
// one per spacing² of area, spread evenly: area-weighted random samples, four per spacing² drawn from
// std::mt19937(seed), thinned to the first sample in each cube of side `spacing` (the grid starts
// half a spacing below the lower corner of mesh.bounds()). The same mesh, spacing and seed give the
// same cloud, with any standard library. Throws mfpc::Error for a spacing that is not a positive
// finite length (or so fine that more than 5e7 samples would be drawn), for a mesh without
// triangles or area, and for a triangle that names a missing vertex.
PointCloud sample_surface(const TriangleMesh& mesh, float spacing, std::uint32_t seed);

}  // namespace mfpc
