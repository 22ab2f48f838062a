#pragma once

/// @file
/// @brief Triangle meshes for the virtual scanner: the built-in household objects, reading PLY and
/// OBJ meshes, and sampling a mesh's surface into a cloud.

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

/// @brief A triangle mesh in metres. Triangles wind counter-clockwise seen from outside, so the
/// right-hand normal of each points out of the object.
struct TriangleMesh {
    std::vector<Eigen::Vector3f> vertices;   ///< The vertices.
    std::vector<Eigen::Vector3i> triangles;  ///< Three vertex indices per triangle.

    /// @brief Whether the mesh has no triangles.
    /// @return triangles.empty().
    bool empty() const noexcept { return triangles.empty(); }
    /// @brief The surface area, summed over the triangles. The indices are not checked.
    /// @return The area (square metres).
    double area() const;
    /// @brief The bounding box of the vertices.
    /// @return The box; invalid (min > max) for a mesh without vertices.
    Box bounds() const;
};

/// @brief The built-in household objects of the virtual scanner, each in its own frame: metres,
/// z up, standing on the plane z = 0, its footprint centred on the z axis.
///
///     carton  gable-top milk carton (box body, two roof slopes, gables and the top fin)
///     bottle  surface of revolution: body, shoulder, neck and cap
///     mug     open cylinder shell with a floor and a handle
///     box     a cracker box (shallower than the carton is wide)
///     jug     detergent-style jug: rounded body, shoulder, cap and a handle
///
/// @return Their names: carton, bottle, mug, box, jug.
std::span<const std::string_view> builtin_object_names();
/// @brief Whether `name` is a built-in object.
/// @param name The name.
/// @return Whether builtin_object_names() holds it.
bool is_builtin_object(std::string_view name);
/// @brief The mesh of a built-in object (see builtin_object_names).
/// @param name The object's name.
/// @return Its mesh, in its own frame.
/// @throws mfpc::Error naming the object for an unknown name.
TriangleMesh make_builtin_object(std::string_view name);
/// @brief The order of the object's rotational symmetry about its z axis: turning it by 360/N
/// degrees leaves the mesh unchanged (carton and box 2, the bottle any angle: 0, mug and jug
/// none: 1).
/// @param name The object's name.
/// @return N (0: any angle; 1: none).
/// @throws mfpc::Error naming the object for an unknown name.
int builtin_object_symmetry(std::string_view name);
/// @brief Whether a half-turn about the object's x axis through its mid-height also leaves the
/// mesh unchanged: the box (its chamfers alike top and bottom) is the same upside down, so its
/// symmetry is dihedral; the carton's gable, the bottle's neck and the handles are not.
/// @param name The object's name.
/// @return Whether the object has that flip symmetry.
/// @throws mfpc::Error naming the object for an unknown name.
bool builtin_object_flips(std::string_view name);

/// @brief Reads a mesh from .ply or .obj.
///
/// .ply: ascii or binary little/big endian; vertex x, y, z as float or double; faces as a list of
/// vertex indices. .obj: v and f records; polygons are fanned into triangles; f indices may be
/// negative or carry /vt/vn parts. The extension decides the format, in any case. Only geometry is
/// kept: other vertex properties, other elements and other OBJ records are skipped. An OBJ face
/// may name only vertices defined above it (as every exporter writes them).
/// @param path The mesh file.
/// @return The mesh.
/// @throws mfpc::Error whose where() is the file, or "file:line" for .obj and ascii .ply, for a
/// missing or unknown extension, a file that cannot be read, and malformed input (bad header,
/// truncated data, an index out of range, a face with fewer than three vertices, non-finite
/// coordinates, no faces).
TriangleMesh read_mesh(const std::filesystem::path& path);

/// @brief Points sampled on the surface with their outward normals (each point's triangle's
/// normal), about one per spacing² of area, spread evenly.
///
/// Area-weighted random samples, four per spacing² drawn from std::mt19937(seed), thinned to the
/// first sample in each cube of side `spacing` (the grid starts half a spacing below the lower
/// corner of mesh.bounds()). The same mesh, spacing and seed give the same cloud, with any
/// standard library.
/// @param mesh The mesh.
/// @param spacing The cube side (metres).
/// @param seed Seeds the samples.
/// @return An unorganized cloud with normals.
/// @throws mfpc::Error for a spacing that is not a positive finite length (or so fine that more
/// than 5e7 samples, or more than 2^21 cubes along an axis, would be needed), for a mesh without
/// triangles or area, for a triangle that names a missing vertex, and for a vertex that is not
/// finite.
PointCloud sample_surface(const TriangleMesh& mesh, float spacing, std::uint32_t seed);

}  // namespace mfpc
