// PLY (Stanford polygon file format 1.0): a text header naming elements and their properties,
// then the elements in header order as ascii, binary_little_endian or binary_big_endian data. Only
// the vertex element becomes the cloud; every other element (faces, edges, lists included) is
// walked to the end of the data, so a truncated face list is caught like a truncated vertex list.
// Bytes after binary data are ignored (some writers end the file with a newline or padding), as the
// PCD reader does; words after ascii data are an error, as ascii rows beyond POINTS are for PCD.

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
#include "mfpc/core/error.hpp"

namespace mfpc::detail {

namespace {

static_assert(std::endian::native == std::endian::little,
              "the PLY reader swaps bytes for binary_big_endian and the writer writes binary_little_endian "
              "assuming a little-endian host");

enum class PlyFormat { ascii, binary_little_endian, binary_big_endian };

struct PlyProperty {
    std::string name;
    bool is_list = false;
    ScalarType type = ScalarType::float32;       // of the value, or of each list item
    ScalarType count_type = ScalarType::uint8;   // of a list's length
};

struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;
};

struct PlyHeader {
    PlyFormat format = PlyFormat::ascii;
    std::vector<PlyElement> elements;
    std::size_t data_start = 0;
};

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

std::optional<ScalarType> ply_scalar_type(std::string_view name)
{
    if (name == "char" || name == "int8") return ScalarType::int8;
    if (name == "uchar" || name == "uint8") return ScalarType::uint8;
    if (name == "short" || name == "int16") return ScalarType::int16;
    if (name == "ushort" || name == "uint16") return ScalarType::uint16;
    if (name == "int" || name == "int32") return ScalarType::int32;
    if (name == "uint" || name == "uint32") return ScalarType::uint32;
    if (name == "float" || name == "float32") return ScalarType::float32;
    if (name == "double" || name == "float64") return ScalarType::float64;
    return std::nullopt;
}

PlyHeader parse_ply_header(std::string_view text, const std::string& where)
{
    PlyHeader header;
    std::vector<std::string_view> tokens;
    std::size_t pos = 0;
    std::size_t line_number = 0;
    bool format_seen = false;
    bool ended = false;
    while (!ended) {
        if (pos >= text.size()) throw Error(where, "header has no end_header line");
        const std::size_t end = text.find('\n', pos);
        const std::string_view line = text.substr(pos, end == std::string_view::npos ? std::string_view::npos : end - pos);
        pos = end == std::string_view::npos ? text.size() : end + 1;
        ++line_number;
        split_words(line, tokens);
        const std::string at_line = "line " + std::to_string(line_number) + ": ";
        if (line_number == 1) {
            if (tokens.size() != 1 || tokens[0] != "ply") {
                throw Error(where, "not a PLY file (first line " + quoted(line) + ", expected 'ply')");
            }
            continue;
        }
        if (tokens.empty()) continue;
        const std::string_view keyword = tokens[0];
        if (keyword == "comment" || keyword == "obj_info") continue;
        if (keyword == "end_header") {
            ended = true;
        } else if (keyword == "format") {
            if (format_seen) throw Error(where, at_line + "second format line");
            format_seen = true;
            if (tokens.size() != 3) throw Error(where, at_line + "format needs a kind and a version, got " + quoted(line));
            if (tokens[1] == "ascii") {
                header.format = PlyFormat::ascii;
            } else if (tokens[1] == "binary_little_endian") {
                header.format = PlyFormat::binary_little_endian;
            } else if (tokens[1] == "binary_big_endian") {
                header.format = PlyFormat::binary_big_endian;
            } else {
                throw Error(where, at_line + "unknown PLY format " + quoted(tokens[1]) +
                                       " (expected ascii, binary_little_endian or binary_big_endian)");
            }
            if (tokens[2] != "1.0") throw Error(where, at_line + "unsupported PLY version " + quoted(tokens[2]));
        } else if (keyword == "element") {
            if (!format_seen) throw Error(where, at_line + "element before the format line");
            PlyElement element;
            if (tokens.size() != 3 || !parse_unsigned(tokens[2], element.count)) {
                throw Error(where, at_line + "element needs a name and a non-negative count, got " + quoted(line));
            }
            element.name = std::string(tokens[1]);
            header.elements.push_back(std::move(element));
        } else if (keyword == "property") {
            if (header.elements.empty()) throw Error(where, at_line + "property before any element");
            PlyProperty property;
            if (tokens.size() == 5 && tokens[1] == "list") {
                const auto count_type = ply_scalar_type(tokens[2]);
                const auto item_type = ply_scalar_type(tokens[3]);
                if (!count_type || !item_type) throw Error(where, at_line + "unknown property type in " + quoted(line));
                if (!is_integer(*count_type)) {
                    throw Error(where, at_line + "list length type " + quoted(tokens[2]) + " is not an integer type");
                }
                property.is_list = true;
                property.count_type = *count_type;
                property.type = *item_type;
                property.name = std::string(tokens[4]);
            } else if (tokens.size() == 3) {
                const auto type = ply_scalar_type(tokens[1]);
                if (!type) throw Error(where, at_line + "unknown property type " + quoted(tokens[1]));
                property.type = *type;
                property.name = std::string(tokens[2]);
            } else {
                throw Error(where, at_line + "malformed property line " + quoted(line));
            }
            header.elements.back().properties.push_back(std::move(property));
        } else {
            throw Error(where, at_line + "unknown header line " + quoted(line));
        }
    }
    if (!format_seen) throw Error(where, "header has no format line");
    header.data_start = pos;
    return header;
}

VertexLayout find_vertex_layout(const PlyHeader& header, const std::string& where)
{
    VertexLayout layout;
    std::optional<std::size_t> vertex;
    for (std::size_t e = 0; e < header.elements.size(); ++e) {
        if (header.elements[e].name != "vertex") continue;
        if (vertex) throw Error(where, "header has two vertex elements");
        vertex = e;
    }
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

// The fewest bytes one item of `element` takes in binary data (lists counted as empty).
std::size_t min_binary_size(const PlyElement& element)
{
    std::size_t size = 0;
    for (const PlyProperty& property : element.properties) {
        size += size_of(property.is_list ? property.count_type : property.type);
    }
    return size;
}

PointCloud read_ply_binary(const PlyHeader& header, const VertexLayout& layout, std::span<const std::uint8_t> data,
                           const std::string& where)
{
    const bool swap_bytes = header.format == PlyFormat::binary_big_endian;
    std::size_t pos = 0;
    std::optional<PointCloud> cloud;
    for (std::size_t e = 0; e < header.elements.size(); ++e) {
        const PlyElement& element = header.elements[e];
        const std::size_t min_size = min_binary_size(element);
        const auto min_total = checked_product(element.count, min_size);
        if (!min_total || *min_total > data.size() - pos) {
            throw Error(where, "binary data is truncated: element '" + element.name + "' has " +
                                   std::to_string(element.count) + " items of at least " + std::to_string(min_size) +
                                   " bytes, " + std::to_string(data.size() - pos) + " bytes remain");
        }
        const bool has_lists = std::any_of(element.properties.begin(), element.properties.end(),
                                           [](const PlyProperty& property) { return property.is_list; });
        const bool is_vertex = e == layout.element;
        if (!is_vertex && !has_lists) {
            pos += *min_total;
            continue;
        }
        const auto truncated = [&](std::uint64_t item) {
            return Error(where, "binary data is truncated in element '" + element.name + "' (item " +
                                    std::to_string(item) + " of " + std::to_string(element.count) + ")");
        };
        std::optional<FiniteCloudBuilder> builder;
        if (is_vertex) builder.emplace(layout.normals, layout.colors, element.count);
        std::array<const std::uint8_t*, slot_count> value_at{};
        for (std::uint64_t item = 0; item < element.count; ++item) {
            for (std::size_t p = 0; p < element.properties.size(); ++p) {
                const PlyProperty& property = element.properties[p];
                if (property.is_list) {
                    const std::size_t count_size = size_of(property.count_type);
                    if (count_size > data.size() - pos) throw truncated(item);
                    std::uint64_t length = 0;
                    if (!load_as_count(data.data() + pos, property.count_type, swap_bytes, length)) {
                        throw Error(where, "element '" + element.name + "' item " + std::to_string(item) +
                                               " has a negative length for list " + property.name);
                    }
                    pos += count_size;
                    const auto list_size = checked_product(length, size_of(property.type));
                    if (!list_size || *list_size > data.size() - pos) throw truncated(item);
                    pos += *list_size;
                    continue;
                }
                const std::size_t size = size_of(property.type);
                if (size > data.size() - pos) throw truncated(item);
                if (is_vertex && layout.slot_of_property[p] >= 0) value_at[layout.slot_of_property[p]] = data.data() + pos;
                pos += size;
            }
            if (!is_vertex) continue;
            const auto value = [&](int slot) { return load_as_float(value_at[slot], layout.types[slot], swap_bytes); };
            const Point point(value(slot_x), value(slot_y), value(slot_z));
            const Point normal = layout.normals ? Point(value(slot_nx), value(slot_ny), value(slot_nz)) : Point::Zero();
            const Rgb color = layout.colors ? Rgb{*value_at[slot_red], *value_at[slot_green], *value_at[slot_blue]} : Rgb{};
            builder->add(static_cast<std::uint32_t>(item), point, normal, color);
        }
        if (is_vertex) {
            cloud = builder->finish(static_cast<std::uint32_t>(element.count), 1, element.count, where);
        }
    }
    return std::move(*cloud);
}

// Whitespace-separated words of ascii data, line breaks included: PLY does not tie items to lines.
class WordCursor {
public:
    explicit WordCursor(std::string_view text) : text_(text) {}

    bool next(std::string_view& word)
    {
        const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
        while (pos_ < text_.size() && is_space(text_[pos_])) ++pos_;
        if (pos_ == text_.size()) return false;
        const std::size_t start = pos_;
        while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
        word = text_.substr(start, pos_ - start);
        return true;
    }

private:
    std::string_view text_;
    std::size_t pos_ = 0;
};

PointCloud read_ply_ascii(const PlyHeader& header, const VertexLayout& layout, std::string_view text,
                          const std::string& where)
{
    WordCursor words(text);
    std::optional<PointCloud> cloud;
    std::string_view word;
    for (std::size_t e = 0; e < header.elements.size(); ++e) {
        const PlyElement& element = header.elements[e];
        const bool is_vertex = e == layout.element;
        if (element.properties.empty()) continue;  // nothing to read, however large its count
        std::uint64_t item = 0;
        const auto next_word = [&] {
            if (!words.next(word)) {
                throw Error(where, "ascii data ends in element '" + element.name + "' (item " + std::to_string(item) +
                                       " of " + std::to_string(element.count) + ")");
            }
        };
        const auto bad_word = [&](const std::string& property, const char* expected) {
            return Error(where, "element '" + element.name + "' item " + std::to_string(item) + ": " + quoted(word) +
                                    " is not " + expected + " (property " + property + ")");
        };
        std::optional<FiniteCloudBuilder> builder;
        if (is_vertex) {
            builder.emplace(layout.normals, layout.colors,
                            std::min<std::uint64_t>(element.count, max_text_rows(text.size(), element.properties.size())));
        }
        std::array<float, slot_count> values{};
        for (; item < element.count; ++item) {
            for (std::size_t p = 0; p < element.properties.size(); ++p) {
                const PlyProperty& property = element.properties[p];
                next_word();
                if (property.is_list) {
                    std::uint64_t length = 0;
                    if (!parse_unsigned(word, length)) throw bad_word(property.name, "a list length");
                    for (std::uint64_t i = 0; i < length; ++i) next_word();
                    continue;
                }
                if (!is_vertex || layout.slot_of_property[p] < 0) continue;
                const int slot = layout.slot_of_property[p];
                if (slot >= slot_red) {
                    std::uint64_t channel = 0;
                    if (!parse_unsigned(word, channel) || channel > 255) throw bad_word(property.name, "a uchar");
                    values[slot] = static_cast<float>(channel);
                } else if (property.type == ScalarType::float32) {
                    if (!parse_float(word, values[slot])) throw bad_word(property.name, "a number");
                } else {
                    double wide = 0;
                    if (!parse_double(word, wide)) throw bad_word(property.name, "a number");
                    values[slot] = narrow_to_float(wide);
                }
            }
            if (!is_vertex) continue;
            const Point point(values[slot_x], values[slot_y], values[slot_z]);
            const Point normal = layout.normals ? Point(values[slot_nx], values[slot_ny], values[slot_nz]) : Point::Zero();
            const Rgb color = layout.colors ? Rgb{static_cast<std::uint8_t>(values[slot_red]),
                                                  static_cast<std::uint8_t>(values[slot_green]),
                                                  static_cast<std::uint8_t>(values[slot_blue])}
                                            : Rgb{};
            builder->add(static_cast<std::uint32_t>(item), point, normal, color);
        }
        if (is_vertex) {
            cloud = builder->finish(static_cast<std::uint32_t>(element.count), 1, element.count, where);
        }
    }
    if (words.next(word)) throw Error(where, "ascii data continues after the last element with " + quoted(word));
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

    PointCloud cloud = header.format == PlyFormat::ascii
                           ? read_ply_ascii(header, layout, text.substr(header.data_start), where)
                           : read_ply_binary(header, layout, file.subspan(header.data_start), where);
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
