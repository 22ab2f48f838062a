// PLY (Stanford polygon file format 1.0) point clouds. The header parser and the data cursor are
// detail/ply.hpp's, shared with the mesh reader: here the vertex element becomes the cloud and
// every other element (faces, edges, lists included) is walked to the end of the data, so a
// truncated face list is caught like a truncated vertex list. Bytes after binary data are ignored
// (some writers end the file with a newline or padding), as the PCD reader does; words after ascii
// data are an error, as ascii rows beyond POINTS are for PCD.

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cloud_format.hpp"
#include "mfpc/core/detail/ply.hpp"
#include "mfpc/core/error.hpp"

namespace mfpc::detail {

namespace {

static_assert(std::endian::native == std::endian::little,
              "the PLY writer writes binary_little_endian assuming a little-endian host");

// The vertex properties that become the cloud, in this order; -1 marks a property the cloud skips.
enum Slot : int { slot_x, slot_y, slot_z, slot_nx, slot_ny, slot_nz, slot_red, slot_green, slot_blue, slot_count };
constexpr std::array<const char*, slot_count> slot_names = {"x", "y", "z", "nx", "ny", "nz", "red", "green", "blue"};
// PCL's PLY writer spells the normal normal_x normal_y normal_z; most other tools write nx ny nz.
constexpr std::array<const char*, 3> pcl_normal_names = {"normal_x", "normal_y", "normal_z"};

// The slot a vertex property fills, or -1.
int slot_of(std::string_view name)
{
    for (int slot = 0; slot < slot_count; ++slot) {
        if (name == slot_names[slot]) return slot;
    }
    for (int axis = 0; axis < 3; ++axis) {
        if (name == pcl_normal_names[axis]) return slot_nx + axis;
    }
    return -1;
}

struct VertexLayout {
    std::size_t element = 0;             // position of the vertex element in the header
    std::vector<int> slot_of_property;   // Slot or -1, per vertex property
    std::array<ScalarType, slot_count> types{};
    bool normals = false;
    bool colors = false;
};

VertexLayout find_vertex_layout(const PlyHeader& header, const std::string& where)
{
    VertexLayout layout;
    const std::optional<std::size_t> vertex = find_ply_element(header, "vertex", where);
    if (!vertex) throw Error(where, "no vertex element");
    layout.element = *vertex;
    const PlyElement& element = header.elements[*vertex];

    std::array<bool, slot_count> found{};
    std::array<std::string_view, slot_count> found_as{};  // the property name that filled each slot
    layout.slot_of_property.assign(element.properties.size(), -1);
    for (std::size_t p = 0; p < element.properties.size(); ++p) {
        const PlyProperty& property = element.properties[p];
        const int slot = slot_of(property.name);
        if (slot < 0) continue;
        if (found[slot] && found_as[slot] == property.name) {
            throw Error(where, "vertex property " + property.name + " appears twice");
        }
        if (found[slot]) {
            throw Error(where, "vertex has both " + std::string(found_as[slot]) + " and " + property.name +
                                   " (expected one spelling of the normal)");
        }
        if (property.is_list) throw Error(where, "vertex property " + property.name + " is a list, expected a number");
        found[slot] = true;
        found_as[slot] = property.name;
        layout.slot_of_property[p] = slot;
        layout.types[slot] = property.type;
    }
    for (int slot : {slot_x, slot_y, slot_z}) {
        if (!found[slot]) throw Error(where, std::string("vertex element has no ") + slot_names[slot] + " property");
    }
    const int normal_count = found[slot_nx] + found[slot_ny] + found[slot_nz];
    if (normal_count != 0 && normal_count != 3) throw Error(where, "normals need all of nx ny nz (or normal_x normal_y normal_z)");
    layout.normals = normal_count == 3;
    const int color_count = found[slot_red] + found[slot_green] + found[slot_blue];
    if (color_count != 0 && color_count != 3) throw Error(where, "colours need all of red green blue");
    layout.colors = color_count == 3;
    if (layout.colors) {
        for (int slot : {slot_red, slot_green, slot_blue}) {
            if (layout.types[slot] != ScalarType::uint8) {
                throw Error(where, std::string("vertex property ") + slot_names[slot] + " is not uchar");
            }
        }
    }
    return layout;
}

// Reads the vertex element into the cloud and walks every other element.
PointCloud read_ply_data(const PlyHeader& header, const VertexLayout& layout, std::string_view file,
                         const std::string& where)
{
    PlyDataCursor data(header, file, where);
    std::optional<PointCloud> cloud;
    for (std::size_t e = 0; e < header.elements.size(); ++e) {
        data.begin_element(e);
        if (e != layout.element) {
            data.skip_element();
            continue;
        }
        const PlyElement& element = header.elements[e];
        // begin_element has checked that binary data holds every vertex; ascii data, whose header
        // can overstate the count, reserves no more rows than its bytes can hold.
        const std::size_t data_size = file.size() - header.data_start;
        FiniteCloudBuilder builder(layout.normals, layout.colors,
                                   header.format != PlyFormat::ascii
                                       ? element.count
                                       : std::min<std::uint64_t>(element.count,
                                                                 max_text_rows(data_size, element.properties.size())));
        std::array<float, slot_count> values{};
        for (std::uint64_t item = 0; item < element.count; ++item) {
            data.begin_item(item);
            for (std::size_t p = 0; p < element.properties.size(); ++p) {
                const int slot = layout.slot_of_property[p];
                if (slot < 0) {
                    data.skip(element.properties[p]);
                } else {
                    values[slot] = narrow_to_float(data.value(element.properties[p]));
                }
            }
            const Point point(values[slot_x], values[slot_y], values[slot_z]);
            const Point normal = layout.normals ? Point(values[slot_nx], values[slot_ny], values[slot_nz]) : Point::Zero();
            // Colours are uchar properties (find_vertex_layout), so their values are whole and in range.
            const Rgb color = layout.colors ? Rgb{static_cast<std::uint8_t>(values[slot_red]),
                                                  static_cast<std::uint8_t>(values[slot_green]),
                                                  static_cast<std::uint8_t>(values[slot_blue])}
                                            : Rgb{};
            builder.add(static_cast<std::uint32_t>(item), point, normal, color);
        }
        cloud = builder.finish(static_cast<std::uint32_t>(element.count), 1, element.count, where);
    }
    data.end();
    return std::move(*cloud);
}

}  // namespace

PointCloud read_ply(std::span<const std::uint8_t> file, const std::string& where, CloudReadReport& report)
{
    const std::string_view text(reinterpret_cast<const char*>(file.data()), file.size());
    const PlyHeader header = parse_ply_header(text, where);
    const VertexLayout layout = find_vertex_layout(header, where);
    const PlyElement& vertex = header.elements[layout.element];

    report.points_in = vertex.count;
    report.points_finite = 0;
    report.height = 1;
    report.fields.clear();
    for (const PlyProperty& property : vertex.properties) report.fields.push_back(property.name);
    report.encoding = header.format == PlyFormat::ascii ? CloudEncoding::ascii : CloudEncoding::binary;
    if (vertex.count == 0) throw Error(where, "no points (element vertex 0)");
    // source_index is uint32: a larger cloud could not say where its points came from.
    if (vertex.count > std::numeric_limits<std::uint32_t>::max()) {
        throw Error(where, "element vertex " + std::to_string(vertex.count) + " is more than 4294967295 points");
    }
    report.width = static_cast<std::uint32_t>(vertex.count);

    PointCloud cloud = read_ply_data(header, layout, text, where);
    report.points_finite = cloud.size();
    return cloud;
}

std::string ply_file_bytes(const PointCloud& cloud, const CloudWriteOptions& options, const std::string& /*where*/)
{
    // write_cloud has refused organized and binary_compressed PLY (check_cloud_write_options).
    const bool binary = options.encoding == CloudEncoding::binary;
    const bool normals = cloud.has_normals();
    const bool colors = cloud.has_colors();
    std::string out = "ply\nformat ";
    out += binary ? "binary_little_endian" : "ascii";
    out += " 1.0\ncomment written by mfpc\nelement vertex " + std::to_string(cloud.size()) +
           "\nproperty float x\nproperty float y\nproperty float z\n";
    if (normals) out += "property float nx\nproperty float ny\nproperty float nz\n";
    if (colors) out += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    out += "end_header\n";

    const std::size_t n = cloud.size();
    if (binary) {
        const std::size_t vertex_size = 12 + (normals ? 12 : 0) + (colors ? 3 : 0);
        std::size_t pos = out.size();
        out.resize(pos + n * vertex_size);
        for (std::size_t i = 0; i < n; ++i) {
            std::memcpy(out.data() + pos, cloud.points[i].data(), 12);
            pos += 12;
            if (normals) {
                std::memcpy(out.data() + pos, cloud.normals[i].data(), 12);
                pos += 12;
            }
            if (colors) {
                const Rgb& color = cloud.colors[i];
                out[pos++] = static_cast<char>(color.r);
                out[pos++] = static_cast<char>(color.g);
                out[pos++] = static_cast<char>(color.b);
            }
        }
        return out;
    }
    out.reserve(out.size() + n * 40);
    for (std::size_t i = 0; i < n; ++i) {
        const auto put = [&](const Point& value) {
            append_float(out, value.x());
            out += ' ';
            append_float(out, value.y());
            out += ' ';
            append_float(out, value.z());
        };
        put(cloud.points[i]);
        if (normals) {
            out += ' ';
            put(cloud.normals[i]);
        }
        if (colors) {
            const Rgb& color = cloud.colors[i];
            out += ' ' + std::to_string(color.r) + ' ' + std::to_string(color.g) + ' ' + std::to_string(color.b);
        }
        out += '\n';
    }
    return out;
}

}  // namespace mfpc::detail
