#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>
#include <numbers>
#include <numeric>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "mfpc/core/error.hpp"
#include "mfpc/simulation/mesh.hpp"
#include "test_support.hpp"
#include "triangle_distance.hpp"

namespace mfpc {
namespace {

using Vec = Eigen::Vector3d;
using test::distance_to_triangle;

Vec corner(const TriangleMesh& mesh, const Eigen::Vector3i& triangle, int k)
{
    return mesh.vertices[static_cast<std::size_t>(triangle[k])].cast<double>();
}

// The connected components of a mesh (triangles that share a vertex belong together), as the list
// of triangle indices of each.
std::vector<std::vector<std::size_t>> components(const TriangleMesh& mesh)
{
    std::vector<std::size_t> parent(mesh.vertices.size());
    std::iota(parent.begin(), parent.end(), std::size_t(0));
    const auto root = [&](std::size_t v) {
        while (parent[v] != v) v = parent[v] = parent[parent[v]];
        return v;
    };
    for (const Eigen::Vector3i& triangle : mesh.triangles) {
        for (int k = 1; k < 3; ++k) {
            parent[root(static_cast<std::size_t>(triangle[k]))] = root(static_cast<std::size_t>(triangle[0]));
        }
    }
    std::map<std::size_t, std::vector<std::size_t>> by_root;
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
        by_root[root(static_cast<std::size_t>(mesh.triangles[t][0]))].push_back(t);
    }
    std::vector<std::vector<std::size_t>> result;
    for (auto& [key, triangles] : by_root) result.push_back(std::move(triangles));
    return result;
}

// The volume enclosed by a closed surface, positive when its triangles wind counter-clockwise
// seen from outside (the divergence theorem with tetrahedra from the origin).
double signed_volume(const TriangleMesh& mesh, const std::vector<std::size_t>& triangles)
{
    double volume = 0.0;
    for (std::size_t t : triangles) {
        const Eigen::Vector3i& triangle = mesh.triangles[t];
        volume += corner(mesh, triangle, 0).dot(corner(mesh, triangle, 1).cross(corner(mesh, triangle, 2))) / 6.0;
    }
    return volume;
}

// Closed and consistently wound: every directed edge a -> b is used by exactly one triangle and its
// reverse b -> a by exactly one other, so every edge is shared by exactly two triangles that
// traverse it in opposite directions. Returns the first offending edge as a message, or "".
std::string edge_problem(const TriangleMesh& mesh)
{
    std::map<std::pair<int, int>, int> directed;
    for (const Eigen::Vector3i& triangle : mesh.triangles) {
        for (int k = 0; k < 3; ++k) ++directed[{triangle[k], triangle[(k + 1) % 3]}];
    }
    for (const auto& [edge, count] : directed) {
        const auto reverse = directed.find({edge.second, edge.first});
        const int reverse_count = reverse == directed.end() ? 0 : reverse->second;
        if (count != 1 || reverse_count != 1) {
            return "edge " + std::to_string(edge.first) + " -> " + std::to_string(edge.second) + " used " +
                   std::to_string(count) + " times, its reverse " + std::to_string(reverse_count) + " times";
        }
    }
    return "";
}

Vec triangle_normal(const TriangleMesh& mesh, const Eigen::Vector3i& triangle)
{
    const Vec a = corner(mesh, triangle, 0);
    return (corner(mesh, triangle, 1) - a).cross(corner(mesh, triangle, 2) - a).normalized();
}

// The bounds of the vertices at most `height` above the floor: the footprint an object stands on,
// which a handle higher up does not widen.
Box footprint(const TriangleMesh& mesh, float height)
{
    std::vector<Point> low;
    for (const Point& v : mesh.vertices) {
        if (v.z() <= height) low.push_back(v);
    }
    return bounding_box(low);
}

// ---- built-in objects ----------------------------------------------------------------------

TEST(BuiltinObjects, NamesInOrder)
{
    const auto names = builtin_object_names();
    ASSERT_EQ(names.size(), 5u);
    EXPECT_EQ(std::vector<std::string_view>(names.begin(), names.end()),
              (std::vector<std::string_view>{"carton", "bottle", "mug", "box", "jug"}));
    for (std::string_view name : names) EXPECT_TRUE(is_builtin_object(name)) << name;
    for (std::string_view name : {"", "Carton", "cup", "carton "}) EXPECT_FALSE(is_builtin_object(name)) << name;
}

TEST(BuiltinObjects, UnknownNameThrows)
{
    try {
        make_builtin_object("cup");
        FAIL() << "no error for an unknown object";
    } catch (const Error& error) {
        EXPECT_EQ(error.where(), "object");
        EXPECT_EQ(error.reason(), "unknown built-in object 'cup' (known: carton, bottle, mug, box, jug)");
    }
}

TEST(BuiltinObjects, ClosedAndWoundOutward)
{
    for (std::string_view name : builtin_object_names()) {
        SCOPED_TRACE(std::string(name));
        const TriangleMesh mesh = make_builtin_object(name);
        ASSERT_FALSE(mesh.empty());
        for (const Eigen::Vector3i& triangle : mesh.triangles) {
            ASSERT_TRUE((triangle.array() >= 0).all() && (triangle.array() < int(mesh.vertices.size())).all());
            // Every triangle has an area, hence a normal for the sampler and the scanner.
            const Vec a = corner(mesh, triangle, 0);
            ASSERT_GT((corner(mesh, triangle, 1) - a).cross(corner(mesh, triangle, 2) - a).norm(), 1e-12);
        }
        EXPECT_EQ(edge_problem(mesh), "");
        // Each part (body, handle, cap) is closed on its own and encloses a positive volume.
        const auto parts = components(mesh);
        const std::size_t expected_parts = name == "mug" ? 2 : name == "jug" ? 3 : 1;
        EXPECT_EQ(parts.size(), expected_parts);
        for (const auto& part : parts) EXPECT_GT(signed_volume(mesh, part), 1e-6);
    }
}

TEST(BuiltinObjects, StandOnTheFloorCentredOnTheAxis)
{
    for (std::string_view name : builtin_object_names()) {
        SCOPED_TRACE(std::string(name));
        const TriangleMesh mesh = make_builtin_object(name);
        const Box bounds = mesh.bounds();
        EXPECT_NEAR(bounds.min.z(), 0.0f, 1e-6f);
        // The footprint is centred whatever a handle does higher up.
        const Box foot = footprint(mesh, 0.005f);
        EXPECT_NEAR(foot.min.x(), -foot.max.x(), 1e-6f);
        EXPECT_NEAR(foot.min.y(), -foot.max.y(), 1e-6f);
        if (name == "mug" || name == "jug") continue;
        EXPECT_NEAR(bounds.min.x(), -bounds.max.x(), 1e-6f);
        EXPECT_NEAR(bounds.min.y(), -bounds.max.y(), 1e-6f);
    }
}

// Each symmetry the ground truth is given (builtin_object_symmetry, builtin_object_flips) maps the
// mesh onto itself: every vertex moved by it lies on the surface. A flip the object does not have
// (the carton's gable, the jug's cap) moves some vertex centimetres off it.
TEST(BuiltinObjects, SymmetriesMapTheMeshOntoItself)
{
    for (std::string_view name : builtin_object_names()) {
        SCOPED_TRACE(std::string(name));
        const TriangleMesh mesh = make_builtin_object(name);
        const float mid_height = 0.5f * (mesh.bounds().min.z() + mesh.bounds().max.z());
        auto farthest_moved = [&](const Eigen::Affine3f& symmetry) {
            double farthest = 0;
            for (const Eigen::Vector3f& v : mesh.vertices)
                farthest = std::max(farthest, test::distance_to_mesh(mesh, symmetry * v));
            return farthest;
        };
        const int order = builtin_object_symmetry(name);
        const float turn = order == 0 ? 0.7f : 2.0f * float(std::numbers::pi) / float(order);
        if (order != 1) {
            EXPECT_LT(farthest_moved(Eigen::Affine3f(Eigen::AngleAxisf(turn, Eigen::Vector3f::UnitZ()))), 1e-4);
        }
        const Eigen::Affine3f flip = Eigen::Translation3f(0, 0, mid_height) *
                                     Eigen::AngleAxisf(float(std::numbers::pi), Eigen::Vector3f::UnitX()) *
                                     Eigen::Translation3f(0, 0, -mid_height);
        if (builtin_object_flips(name)) {
            EXPECT_LT(farthest_moved(flip), 1e-4);
        } else {
            EXPECT_GT(farthest_moved(flip), 0.005);
        }
    }
}

TEST(BuiltinObjects, RealSizes)
{
    struct Expected {
        std::string_view name;
        Eigen::Vector3f min;
        Eigen::Vector3f max;
    };
    // Body sizes from the real objects; the mug's handle sticks out at +x, the jug's at -x.
    const std::vector<Expected> expected = {
        {"carton", {-0.035f, -0.035f, 0.0f}, {0.035f, 0.035f, 0.23f}},
        {"bottle", {-0.033f, -0.033f, 0.0f}, {0.033f, 0.033f, 0.25f}},
        {"mug", {-0.040f, -0.040f, 0.0f}, {0.074f, 0.040f, 0.095f}},
        {"box", {-0.10f, -0.025f, 0.0f}, {0.10f, 0.025f, 0.26f}},
        {"jug", {-0.092f, -0.045f, 0.0f}, {0.070f, 0.045f, 0.205f}},
    };
    for (const Expected& object : expected) {
        SCOPED_TRACE(std::string(object.name));
        const Box bounds = make_builtin_object(object.name).bounds();
        for (int axis = 0; axis < 3; ++axis) {
            EXPECT_NEAR(bounds.min[axis], object.min[axis], 1e-3f) << "axis " << axis;
            EXPECT_NEAR(bounds.max[axis], object.max[axis], 1e-3f) << "axis " << axis;
        }
    }
}

TEST(BuiltinObjects, MugIsOpenAtTheTop)
{
    // A ray down the axis of the mug meets the floor inside the cup (z = 8 mm), not a lid: the only
    // triangles crossing the axis are the outer bottom and the inner floor.
    const TriangleMesh mesh = make_builtin_object("mug");
    std::set<float> heights;
    for (const Point& v : mesh.vertices) {
        if (v.x() == 0.0f && v.y() == 0.0f) heights.insert(v.z());
    }
    EXPECT_EQ(heights, (std::set<float>{0.0f, 0.008f}));
}

// ---- sampling ------------------------------------------------------------------------------

TEST(SampleSurface, PointsOnTheMeshWithItsNormals)
{
    const double tolerance = 1e-5;
    for (std::string_view name : builtin_object_names()) {
        SCOPED_TRACE(std::string(name));
        const TriangleMesh mesh = make_builtin_object(name);
        const PointCloud cloud = sample_surface(mesh, 0.006f, 7);
        ASSERT_GT(cloud.size(), 100u);
        ASSERT_EQ(cloud.normals.size(), cloud.size());
        EXPECT_EQ(cloud.width, cloud.size());
        EXPECT_EQ(cloud.height, 1u);
        // Triangle boxes grown by the tolerance rule out most triangles at once (the test also runs
        // under the sanitizers, where the plain all-pairs search is slow).
        std::vector<Box> near_boxes;
        for (const Eigen::Vector3i& triangle : mesh.triangles) {
            const std::array<Point, 3> corners = {mesh.vertices[std::size_t(triangle[0])],
                                                  mesh.vertices[std::size_t(triangle[1])],
                                                  mesh.vertices[std::size_t(triangle[2])]};
            Box box = bounding_box(corners);
            box.min.array() -= float(tolerance);
            box.max.array() += float(tolerance);
            near_boxes.push_back(box);
        }
        std::size_t off_mesh = 0;
        std::size_t wrong_normal = 0;
        for (std::size_t i = 0; i < cloud.size(); ++i) {
            const Vec p = cloud.points[i].cast<double>();
            const Vec n = cloud.normals[i].cast<double>();
            EXPECT_NEAR(n.norm(), 1.0, 1e-6);
            // A point on an edge is near two triangles: its normal is that of one of them.
            bool on_mesh = false;
            bool normal_matches = false;
            for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
                if (!near_boxes[t].contains(cloud.points[i])) continue;
                const Eigen::Vector3i& triangle = mesh.triangles[t];
                const double distance = distance_to_triangle(p, corner(mesh, triangle, 0), corner(mesh, triangle, 1),
                                                             corner(mesh, triangle, 2));
                if (distance >= tolerance) continue;
                on_mesh = true;
                if ((triangle_normal(mesh, triangle) - n).norm() < 1e-5) normal_matches = true;
            }
            off_mesh += !on_mesh;
            wrong_normal += on_mesh && !normal_matches;
        }
        EXPECT_EQ(off_mesh, 0u);
        EXPECT_EQ(wrong_normal, 0u);
    }
}

TEST(SampleSurface, AboutOnePointPerSpacingSquared)
{
    for (std::string_view name : builtin_object_names()) {
        const TriangleMesh mesh = make_builtin_object(name);
        for (const float spacing : {0.004f, 0.008f}) {
            const double expected = mesh.area() / (double(spacing) * double(spacing));
            const double count = double(sample_surface(mesh, spacing, 1).size());
            EXPECT_GT(count, 0.7 * expected) << name << " at " << spacing;
            EXPECT_LT(count, 1.3 * expected) << name << " at " << spacing;
        }
    }
}

TEST(SampleSurface, OnePointPerVoxel)
{
    // The voxel grid starts half a spacing below the mesh's lower corner (see sample_surface).
    for (std::string_view name : builtin_object_names()) {
        const TriangleMesh mesh = make_builtin_object(name);
        const float spacing = 0.005f;
        const PointCloud cloud = sample_surface(mesh, spacing, 3);
        const Vec origin = mesh.bounds().min.cast<double>() - Vec::Constant(0.5 * double(spacing));
        std::set<std::array<long, 3>> voxels;
        for (const Point& p : cloud.points) {
            std::array<long, 3> voxel{};
            for (int axis = 0; axis < 3; ++axis) {
                voxel[static_cast<std::size_t>(axis)] =
                    std::lround(std::floor((double(p[axis]) - origin[axis]) / double(spacing)));
            }
            voxels.insert(voxel);
        }
        EXPECT_EQ(voxels.size(), cloud.size()) << name;
    }
}

TEST(SampleSurface, SeedDecides)
{
    const TriangleMesh mesh = make_builtin_object("bottle");
    const PointCloud a = sample_surface(mesh, 0.005f, 11);
    const PointCloud b = sample_surface(mesh, 0.005f, 11);
    const PointCloud c = sample_surface(mesh, 0.005f, 12);
    EXPECT_EQ(a.points, b.points);
    EXPECT_EQ(a.normals, b.normals);
    EXPECT_NE(a.points, c.points);
}

TEST(SampleSurface, RejectsBadSpacingAndEmptyMeshes)
{
    const TriangleMesh mesh = make_builtin_object("box");
    for (const float spacing : {0.0f, -0.01f, std::numeric_limits<float>::quiet_NaN(),
                                std::numeric_limits<float>::infinity()}) {
        try {
            sample_surface(mesh, spacing, 1);
            ADD_FAILURE() << "no error for spacing " << spacing;
        } catch (const Error& error) {
            EXPECT_EQ(error.where(), "spacing");
        }
    }
    EXPECT_THROW(sample_surface(TriangleMesh{}, 0.01f, 1), Error);
    // So fine a spacing would need billions of samples: refused instead of exhausting memory.
    EXPECT_THROW(sample_surface(mesh, 1e-6f, 1), Error);
    TriangleMesh broken = mesh;
    broken.triangles.back()[2] = int(broken.vertices.size());
    EXPECT_THROW(sample_surface(broken, 0.01f, 1), Error);
}

// ---- reading -------------------------------------------------------------------------------

// A unit cube: 8 corners, 6 outward quads.
const std::vector<Point> cube_vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0},
                                          {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
const std::vector<std::array<int, 4>> cube_quads = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4},
                                                    {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};

// The cube's quads fanned as the readers fan them: (a, b, c) and (a, c, d).
std::vector<Eigen::Vector3i> cube_triangles()
{
    std::vector<Eigen::Vector3i> triangles;
    for (const auto& q : cube_quads) {
        triangles.emplace_back(q[0], q[1], q[2]);
        triangles.emplace_back(q[0], q[2], q[3]);
    }
    return triangles;
}

void expect_cube(const TriangleMesh& mesh)
{
    EXPECT_EQ(mesh.vertices, cube_vertices);
    EXPECT_EQ(mesh.triangles, cube_triangles());
    EXPECT_DOUBLE_EQ(mesh.area(), 6.0);
    EXPECT_EQ(edge_problem(mesh), "");
    std::vector<std::size_t> all(mesh.triangles.size());
    std::iota(all.begin(), all.end(), std::size_t(0));
    EXPECT_DOUBLE_EQ(signed_volume(mesh, all), 1.0);
}

std::string cube_ascii_ply()
{
    std::string text =
        "ply\n"
        "format ascii 1.0\n"
        "comment a unit cube, with properties and elements the reader skips\n"
        "element vertex 8\n"
        "property float x\n"
        "property float y\n"
        "property float z\n"
        "property uchar red\n"
        "element edge 1\n"
        "property int vertex1\n"
        "property int vertex2\n"
        "element face 6\n"
        "property uchar flags\n"
        "property list uchar int vertex_indices\n"
        "element note 1\n"
        "property list uchar float values\n"
        "end_header\n";
    for (const Point& v : cube_vertices) text += std::to_string(int(v.x())) + " " + std::to_string(int(v.y())) + " " +
                                                 std::to_string(int(v.z())) + " 200\n";
    text += "0 1\n";
    for (const auto& q : cube_quads) {
        text += "7 4 " + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " + std::to_string(q[2]) + " " +
                std::to_string(q[3]) + "\n";
    }
    text += "3 1.5 2.5 3.5\n";
    return text;
}

// Appends `value` in little- or big-endian byte order.
template <class T>
void put(std::string& out, T value, bool big_endian)
{
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (big_endian == (std::endian::native == std::endian::little)) std::reverse(bytes, bytes + sizeof(T));
    out.append(bytes, sizeof(T));
}

// The cube in binary, with double coordinates, a list-carrying element before the vertices, a
// fixed-size element between vertices and faces and a uint-counted index list named vertex_index.
std::string cube_binary_ply(bool big_endian)
{
    std::string out = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                      " 1.0\n"
                      "element material 2\n"
                      "property list uchar uchar name\n"
                      "element vertex 8\n"
                      "property double x\n"
                      "property float confidence\n"
                      "property double y\n"
                      "property double z\n"
                      "element edge 1\n"
                      "property int vertex1\n"
                      "property int vertex2\n"
                      "element face 6\n"
                      "property list uint int vertex_index\n"
                      "property short flags\n"
                      "end_header\n";
    for (int m = 0; m < 2; ++m) {
        put<std::uint8_t>(out, 3, big_endian);
        for (int i = 0; i < 3; ++i) put<std::uint8_t>(out, 'a', big_endian);
    }
    for (const Point& v : cube_vertices) {
        put<double>(out, v.x(), big_endian);
        put<float>(out, 0.5f, big_endian);
        put<double>(out, v.y(), big_endian);
        put<double>(out, v.z(), big_endian);
    }
    put<std::int32_t>(out, 0, big_endian);
    put<std::int32_t>(out, 1, big_endian);
    for (const auto& q : cube_quads) {
        put<std::uint32_t>(out, 4, big_endian);
        for (int index : q) put<std::int32_t>(out, index, big_endian);
        put<std::int16_t>(out, -1, big_endian);
    }
    return out;
}

const char* const cube_obj =
    "# a unit cube with the records a mesh does not keep\n"
    "mtllib cube.mtl\n"
    "o cube\n"
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 1 1 0  # a comment after a record\n"
    "v 0 1 0\n"
    "vt 0 0\n"
    "vn 0 0 -1\n"
    "g bottom\n"
    "usemtl white\n"
    "s off\n"
    "f 1/1/1 4/1/1 3/1/1 2/1/1\n"
    "v 0 0 1 1.0\n"           // with w
    "v 1 0 1 0.5 0.5 0.5\n"   // with a colour
    "v 1 1 1\n"
    "\tv 0 1 1\r\n"
    "f -4 -3 -2 -1\n"
    "f 1//1 2//1 6//1 5//1\n"
    "f 2/1 3/1 7/1 6/1\n"
    "f 3 4 8 7\n"
    "f 4 1 5 8\n"
    "l 1 2\n";

TEST(ReadMesh, AsciiPly)
{
    const test::TempDir dir;
    expect_cube(read_mesh(dir.write("cube.ply", cube_ascii_ply())));
}

TEST(ReadMesh, BinaryPlyInBothByteOrders)
{
    const test::TempDir dir;
    expect_cube(read_mesh(dir.write("little.ply", cube_binary_ply(false))));
    expect_cube(read_mesh(dir.write("big.ply", cube_binary_ply(true))));
    // Bytes after the data are padding, as some writers leave it.
    expect_cube(read_mesh(dir.write("padded.ply", cube_binary_ply(false) + "\n")));
}

TEST(ReadMesh, Obj)
{
    const test::TempDir dir;
    expect_cube(read_mesh(dir.write("cube.obj", cube_obj)));
}

TEST(ReadMesh, ExtensionIgnoresCase)
{
    const test::TempDir dir;
    expect_cube(read_mesh(dir.write("cube.PLY", cube_ascii_ply())));
    expect_cube(read_mesh(dir.write("cube.Obj", cube_obj)));
}

TEST(ReadMesh, BuiltinObjectRoundTripsThroughObj)
{
    const TriangleMesh jug = make_builtin_object("jug");
    std::string text;
    char line[96];
    for (const Point& v : jug.vertices) {
        // Nine significant digits give back exactly the same float.
        std::snprintf(line, sizeof(line), "v %.9g %.9g %.9g\n", double(v.x()), double(v.y()), double(v.z()));
        text += line;
    }
    for (const Eigen::Vector3i& t : jug.triangles) {
        std::snprintf(line, sizeof(line), "f %d %d %d\n", t[0] + 1, t[1] + 1, t[2] + 1);
        text += line;
    }
    const test::TempDir dir;
    const TriangleMesh read = read_mesh(dir.write("jug.obj", text));
    EXPECT_EQ(read.vertices, jug.vertices);
    EXPECT_EQ(read.triangles, jug.triangles);
}

// Reading `file` throws mfpc::Error whose where() is `where` and whose reason contains `reason`.
void expect_read_error(const std::filesystem::path& file, const std::string& where, const std::string& reason)
{
    try {
        read_mesh(file);
        ADD_FAILURE() << "no error reading " << file;
    } catch (const Error& error) {
        EXPECT_EQ(error.where(), where) << error.what();
        EXPECT_NE(error.reason().find(reason), std::string::npos) << error.what();
    }
}

std::string replaced(std::string text, const std::string& from, const std::string& to)
{
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    return text.replace(at, from.size(), to);
}

TEST(ReadMesh, RejectsMissingFilesAndUnknownExtensions)
{
    const test::TempDir dir;
    const auto missing = dir / "missing.ply";
    expect_read_error(missing, missing.string(), "no such file");
    const auto stl = dir.write("cube.stl", cube_ascii_ply());
    expect_read_error(stl, stl.string(), "unknown extension '.stl'");
    const auto bare = dir.write("cube", cube_ascii_ply());
    expect_read_error(bare, bare.string(), "no file extension");
}

TEST(ReadMesh, RejectsMalformedPly)
{
    const test::TempDir dir;
    const std::string cube = cube_ascii_ply();
    // The vertex data starts on line 18, the faces on line 27. Errors name the file as where(), and
    // in ascii data the line in the reason, as core's PLY reader words them for clouds.
    const auto check = [&](const std::string& name, const std::string& text, const std::string& reason) {
        SCOPED_TRACE(name);
        const auto file = dir.write(name, text);
        expect_read_error(file, file.string(), reason);
    };
    check("not.ply", replaced(cube, "ply\n", "plx\n"), "not a PLY file (first line 'plx'");
    check("no_end.ply", cube.substr(0, cube.find("end_header")), "no end_header");
    check("nan.ply", replaced(cube, "1 1 1 200", "1 nan 1 200"), "line 24: vertex 6: coordinate nan is not finite");
    check("range.ply", replaced(cube, "7 4 1 2 6 5", "7 4 1 2 8 5"),
          "line 30: face 3: vertex index 8 out of range (8 vertices)");
    check("two.ply", replaced(cube, "7 4 1 2 6 5", "7 2 1 2"), "line 30: face 3 has 2 vertices");
    check("short.ply", cube.substr(0, cube.find("7 4 2 3 7 6")),
          "line 30: ascii data ends in element 'face' (item 4 of 6)");
    check("long.ply", cube + "9\n", "line 34: ascii data continues after the last element with '9'");
    check("no_faces.ply", replaced(cube, "element face 6", "element face 0"), "no faces");
    check("no_face_element.ply",
          "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n"
          "end_header\n0 0 0\n",
          "no faces");
    check("word.ply", replaced(cube, "0 0 1 200", "0 0 one 200"),
          "line 22: element 'vertex' item 4: 'one' is not a number");
    check("length.ply", replaced(cube, "7 4 1 2 6 5", "7 1e30 1 2 6 5"),
          "line 30: element 'face' item 3: '1e30' is not a list length");
    check("fraction.ply", replaced(cube, "7 4 1 2 6 5", "7 4 1 2.5 6 5"),
          "line 30: element 'face' item 3: '2.5' is not an int");

    // Binary: cut inside the face data; a double beyond float's range.
    const std::string binary = cube_binary_ply(false);
    check("truncated.ply", binary.substr(0, binary.size() - 5),
          "binary data is truncated in element 'face' (item 5 of 6)");
    check("truncated_vertices.ply", binary.substr(0, binary.find("end_header\n") + 11 + 8 + 40),
          "binary data is truncated: element 'vertex' has 8 items of at least 28 bytes, 40 bytes remain");
    std::string huge = binary;
    const std::size_t first_x = huge.find("end_header\n") + 11 + 8;
    const double beyond = 1e300;
    std::memcpy(huge.data() + first_x, &beyond, sizeof(beyond));
    check("huge.ply", huge, "vertex 0: coordinate 1e+300 is beyond ±1e9, the supported range");
    // Finite as a float, but beyond what Embree's rays can take.
    const double far = 2e9;
    std::memcpy(huge.data() + first_x, &far, sizeof(far));
    check("far.ply", huge, "vertex 0: coordinate 2e+09 is beyond ±1e9, the supported range");
}

TEST(ReadMesh, RejectsMalformedObj)
{
    const test::TempDir dir;
    const auto check = [&](const std::string& name, const std::string& text, const std::string& line,
                           const std::string& reason) {
        SCOPED_TRACE(name);
        const auto file = dir.write(name, text);
        expect_read_error(file, file.string() + line, reason);
    };
    const std::string triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    check("range.obj", triangle + "f 1 2 9\n", ":4", "face index 9 out of range (3 vertices before this line)");
    check("back.obj", triangle + "f -4 1 2\n", ":4", "face index -4 out of range");
    check("zero.obj", triangle + "f 0 1 2\n", ":4", "face index 0 out of range");
    check("forward.obj", "f 1 2 3\n" + triangle, ":1", "face index 1 out of range (0 vertices before this line)");
    check("two.obj", triangle + "f 1 2\n", ":4", "face has 2 vertices");
    check("inf.obj", "v 0 inf 0\n" + triangle + "f 2 3 4\n", ":1", "vertex coordinate inf is not finite");
    check("nan.obj", triangle + "v nan 0 0\nf 1 2 3\n", ":4", "vertex coordinate nan is not finite");
    check("far.obj", triangle + "v 0 1e19 0\nf 1 2 4\n", ":4", "vertex coordinate 1e+19 is beyond ±1e9");
    check("word.obj", "v 0 zero 0\n", ":1", "'zero' is not a number");
    check("short_vertex.obj", "v 0 0\n", ":1", "vertex needs x y z");
    check("corner.obj", triangle + "f 1 x 3\n", ":4", "face corner 'x' has no vertex index");
    check("no_faces.obj", triangle, "", "no faces");
}

}  // namespace
}  // namespace mfpc
