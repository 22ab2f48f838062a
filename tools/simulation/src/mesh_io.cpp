// Reading triangle meshes from PLY and OBJ files. Both readers check every index against the
// vertex count and every coordinate for finiteness while reading, so a mesh that comes back is
// safe to index and to sample. Only geometry is read: normals, texture coordinates, colours and
// materials are skipped, because the scanner computes its own normals from the triangles.

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mfpc/core/detail/ply.hpp"
#include "mfpc/core/detail/text_parse.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/text_file.hpp"
#include "mfpc/simulation/mesh.hpp"

namespace mfpc {

namespace {

// Triangles hold int indices.
constexpr std::uint64_t max_vertices = std::numeric_limits<int>::max();

// A coordinate as the mesh stores it, or what is wrong with it: beyond ±max_coordinate Embree's
// ray arithmetic overflows (and beyond float's range the cast is undefined), so it is refused
// like NaN and Inf.
std::optional<std::string> to_coordinate(double value, float& coordinate)
{
    if (std::isfinite(value) && std::abs(value) <= double(max_coordinate)) {
        coordinate = static_cast<float>(value);
        return std::nullopt;
    }
    char text[32];
    std::snprintf(text, sizeof(text), "%g", value);
    return "coordinate " + std::string(text) +
           (std::isfinite(value) ? std::string(" is beyond ±") + max_coordinate_text + ", the supported range"
                                 : std::string(" is not finite"));
}

// Fans a polygon (indices already checked) into triangles around its first vertex.
void add_polygon(TriangleMesh& mesh, const std::vector<int>& polygon)
{
    for (std::size_t i = 1; i + 1 < polygon.size(); ++i) {
        mesh.triangles.emplace_back(polygon[0], polygon[i], polygon[i + 1]);
    }
}

// ---- PLY ------------------------------------------------------------------------------------
// The header and the data are core's (detail/ply.hpp), as the point cloud reader reads them; what
// is here is where a mesh is in them and what makes it a valid mesh.

// Where the reader finds the mesh in the header's elements.
struct PlyLayout {
    std::size_t vertex = 0;            // element index
    std::array<std::size_t, 3> xyz{};  // property indices of x, y, z in the vertex element
    std::size_t face = 0;              // element index
    std::size_t indices = 0;           // property index of the index list in the face element
};

PlyLayout find_layout(const detail::PlyHeader& header, const std::string& file)
{
    PlyLayout layout;
    const std::optional<std::size_t> vertex = detail::find_ply_element(header, "vertex", file);
    const std::optional<std::size_t> face = detail::find_ply_element(header, "face", file);
    if (!vertex) throw Error(file, "no vertex element");
    if (!face || header.elements[*face].count == 0) throw Error(file, "no faces");
    layout.vertex = *vertex;
    layout.face = *face;

    const detail::PlyElement& vertices = header.elements[*vertex];
    if (vertices.count > max_vertices) {
        throw Error(file, std::to_string(vertices.count) + " vertices are more than a mesh can index");
    }
    const std::array<const char*, 3> axes = {"x", "y", "z"};
    for (std::size_t axis = 0; axis < 3; ++axis) {
        const auto found =
            std::find_if(vertices.properties.begin(), vertices.properties.end(),
                         [&](const detail::PlyProperty& property) { return property.name == axes[axis]; });
        if (found == vertices.properties.end()) {
            throw Error(file, std::string("vertex element has no ") + axes[axis] + " property");
        }
        if (found->is_list) {
            throw Error(file, std::string("vertex property ") + axes[axis] + " is a list, expected a number");
        }
        layout.xyz[axis] = static_cast<std::size_t>(found - vertices.properties.begin());
    }

    const detail::PlyElement& faces = header.elements[*face];
    const auto found =
        std::find_if(faces.properties.begin(), faces.properties.end(), [](const detail::PlyProperty& property) {
            return property.name == "vertex_indices" || property.name == "vertex_index";
        });
    if (found == faces.properties.end()) throw Error(file, "face element has no vertex_indices list");
    if (!found->is_list || !detail::is_integer(found->type)) {
        throw Error(file, "face property " + found->name + " is not a list of integers");
    }
    layout.indices = static_cast<std::size_t>(found - faces.properties.begin());
    return layout;
}

// One vertex: x, y and z as floats, the other properties passed over.
Eigen::Vector3f read_vertex(detail::PlyDataCursor& data, const detail::PlyElement& element, const PlyLayout& layout,
                            std::uint64_t item)
{
    std::array<double, 3> xyz{};
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const auto axis = std::find(layout.xyz.begin(), layout.xyz.end(), p);
        if (axis == layout.xyz.end()) {
            data.skip(element.properties[p]);
        } else {
            xyz[static_cast<std::size_t>(axis - layout.xyz.begin())] = data.value(element.properties[p]);
        }
    }
    Eigen::Vector3f point;
    for (int axis = 0; axis < 3; ++axis) {
        if (const auto problem = to_coordinate(xyz[static_cast<std::size_t>(axis)], point[axis])) {
            throw data.error("vertex " + std::to_string(item) + ": " + *problem);
        }
    }
    return point;
}

// One face: its index list fanned into triangles, the other properties passed over.
void read_face(detail::PlyDataCursor& data, const detail::PlyElement& element, const PlyLayout& layout,
               std::uint64_t item, std::uint64_t vertex_count, std::vector<int>& polygon, TriangleMesh& mesh)
{
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const detail::PlyProperty& property = element.properties[p];
        if (p != layout.indices) {
            data.skip(property);
            continue;
        }
        const std::uint64_t length = data.list_length(property);
        if (length < 3) {
            throw data.error("face " + std::to_string(item) + " has " + std::to_string(length) +
                             " vertices (a face needs at least 3)");
        }
        polygon.clear();
        for (std::uint64_t i = 0; i < length; ++i) {
            const double index = data.value(property);  // whole: the list holds integers (find_layout)
            if (index < 0.0 || index >= double(vertex_count)) {
                throw data.error("face " + std::to_string(item) + ": vertex index " +
                                 std::to_string(static_cast<std::int64_t>(index)) + " out of range (" +
                                 std::to_string(vertex_count) + " vertices)");
            }
            polygon.push_back(static_cast<int>(index));
        }
        add_polygon(mesh, polygon);
    }
}

TriangleMesh read_ply(std::string_view text, const std::string& file)
{
    const detail::PlyHeader header = detail::parse_ply_header(text, file);
    const PlyLayout layout = find_layout(header, file);
    detail::PlyDataCursor data(header, text, file);
    TriangleMesh mesh;
    const std::uint64_t vertex_count = header.elements[layout.vertex].count;
    // Counts come from the header, which may overstate them: a false count in a small file must not
    // reserve gigabytes. Six bytes a vertex is the least ascii data ("0 0 0\n") takes.
    const std::size_t data_size = text.size() - header.data_start;
    mesh.vertices.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(vertex_count, data_size / 6)));
    std::vector<int> polygon;
    for (std::size_t e = 0; e < header.elements.size(); ++e) {
        data.begin_element(e);
        if (e != layout.vertex && e != layout.face) {
            data.skip_element();
            continue;
        }
        const detail::PlyElement& element = header.elements[e];
        for (std::uint64_t item = 0; item < element.count; ++item) {
            data.begin_item(item);
            if (e == layout.vertex) {
                mesh.vertices.push_back(read_vertex(data, element, layout, item));
            } else {
                read_face(data, element, layout, item, vertex_count, polygon, mesh);
            }
        }
    }
    data.end();
    return mesh;
}

// ---- OBJ ------------------------------------------------------------------------------------

// One face corner, "v", "v/vt", "v//vn" or "v/vt/vn": the vertex is the part before the first
// slash. OBJ counts from 1, and a negative index counts back from the last vertex read so far.
int obj_vertex(std::string_view corner, std::size_t vertex_count, const std::string& where)
{
    const std::string_view index_text = corner.substr(0, corner.find('/'));
    std::int64_t index = 0;
    if (!detail::parse_signed(index_text, index)) {
        throw Error(where, "face corner " + detail::quoted(corner) + " has no vertex index");
    }
    const auto count = static_cast<std::int64_t>(vertex_count);
    const std::int64_t resolved = index > 0 ? index - 1 : count + index;
    if (index == 0 || resolved < 0 || resolved >= count) {
        throw Error(where, "face index " + std::to_string(index) + " out of range (" + std::to_string(vertex_count) +
                               " vertices before this line)");
    }
    return static_cast<int>(resolved);
}

TriangleMesh read_obj(std::string_view text, const std::string& file)
{
    TriangleMesh mesh;
    std::vector<std::string_view> words;
    std::vector<int> polygon;
    std::size_t pos = 0;
    std::size_t line_number = 0;
    while (pos < text.size()) {
        const std::size_t end = text.find('\n', pos);
        std::string_view line = text.substr(pos, end == std::string_view::npos ? text.size() - pos : end - pos);
        pos = end == std::string_view::npos ? text.size() : end + 1;
        ++line_number;
        line = line.substr(0, line.find('#'));
        detail::split_words(line, words);
        if (words.empty()) continue;
        const std::string where = file + ":" + std::to_string(line_number);
        if (words[0] == "v") {
            // "v x y z", optionally followed by w or by a colour, which a mesh does not keep.
            if (words.size() < 4) throw Error(where, "vertex needs x y z");
            Eigen::Vector3f point;
            for (int axis = 0; axis < 3; ++axis) {
                const std::string_view word = words[static_cast<std::size_t>(axis) + 1];
                double value = 0.0;
                if (!detail::parse_double(word, value)) throw Error(where, detail::quoted(word) + " is not a number");
                if (const auto problem = to_coordinate(value, point[axis])) throw Error(where, "vertex " + *problem);
            }
            if (mesh.vertices.size() == max_vertices) throw Error(where, "more vertices than a mesh can index");
            mesh.vertices.push_back(point);
        } else if (words[0] == "f") {
            if (words.size() < 4) {
                throw Error(where,
                            "face has " + std::to_string(words.size() - 1) + " vertices (a face needs at least 3)");
            }
            polygon.clear();
            for (std::size_t i = 1; i < words.size(); ++i) {
                polygon.push_back(obj_vertex(words[i], mesh.vertices.size(), where));
            }
            add_polygon(mesh, polygon);
        }
        // Every other record (vt, vn, g, o, s, usemtl, mtllib, l, ...) carries nothing a mesh keeps.
    }
    if (mesh.triangles.empty()) throw Error(file, "no faces");
    return mesh;
}

}  // namespace

TriangleMesh read_mesh(const std::filesystem::path& path)
{
    const std::string file = path.string();
    std::string extension = path.extension().string();
    for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (extension != ".ply" && extension != ".obj") {
        if (extension.empty()) throw Error(file, "no file extension (expected .ply or .obj)");
        throw Error(file, "unknown extension " + detail::quoted(path.extension().string()) + " (expected .ply or .obj)");
    }
    const std::string bytes = read_text_file(path);
    return extension == ".ply" ? read_ply(bytes, file) : read_obj(bytes, file);
}

}  // namespace mfpc
