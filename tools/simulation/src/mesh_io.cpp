// Reading triangle meshes from PLY and OBJ files. Both readers check every index against the
// vertex count and every coordinate for finiteness while reading, so a mesh that comes back is
// safe to index and to sample. Only geometry is read: normals, texture coordinates, colours and
// materials are skipped, because the scanner computes its own normals from the triangles.

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/text_file.hpp"
#include "mfpc/simulation/mesh.hpp"

namespace mfpc {

namespace {

static_assert(std::endian::native == std::endian::little,
              "the PLY reader swaps bytes for binary_big_endian assuming a little-endian host");

// Triangles hold int indices.
constexpr std::uint64_t max_vertices = std::numeric_limits<int>::max();

// `text` in quotes for a one-line message: at most 40 characters, control bytes shown as '?'.
std::string quote_word(std::string_view text)
{
    std::string out = "'";
    for (std::size_t i = 0; i < text.size() && i < 40; ++i) {
        const auto c = static_cast<unsigned char>(text[i]);
        out += (c < 0x20 || c == 0x7f) ? '?' : text[i];
    }
    if (text.size() > 40) out += "...";
    return out + "'";
}

void split_words(std::string_view line, std::vector<std::string_view>& words)
{
    words.clear();
    const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; };
    std::size_t pos = 0;
    while (true) {
        while (pos < line.size() && is_space(line[pos])) ++pos;
        if (pos == line.size()) return;
        const std::size_t start = pos;
        while (pos < line.size() && !is_space(line[pos])) ++pos;
        words.push_back(line.substr(start, pos - start));
    }
}

// Whole-word number parsers; a leading '+' is allowed, as C's strtod allows it.
bool parse_double(std::string_view word, double& value)
{
    if (word.size() > 1 && word[0] == '+' && word[1] != '-' && word[1] != '+') word.remove_prefix(1);
    const auto [end, error] = std::from_chars(word.data(), word.data() + word.size(), value);
    return error == std::errc() && end == word.data() + word.size();
}

bool parse_integer(std::string_view word, std::int64_t& value)
{
    if (word.size() > 1 && word[0] == '+' && word[1] != '-' && word[1] != '+') word.remove_prefix(1);
    const auto [end, error] = std::from_chars(word.data(), word.data() + word.size(), value);
    return error == std::errc() && end == word.data() + word.size();
}

// A coordinate as the mesh stores it, or what is wrong with it: a double beyond float's range
// would become infinity (and casting it is undefined behaviour), so it is refused like NaN and Inf.
std::optional<std::string> to_coordinate(double value, float& coordinate)
{
    if (std::isfinite(value) && std::abs(value) <= double(std::numeric_limits<float>::max())) {
        coordinate = static_cast<float>(value);
        return std::nullopt;
    }
    char text[32];
    std::snprintf(text, sizeof(text), "%g", value);
    return "coordinate " + std::string(text) + (std::isfinite(value) ? " is beyond float range" : " is not finite");
}

// Fans a polygon (indices already checked) into triangles around its first vertex.
void add_polygon(TriangleMesh& mesh, const std::vector<int>& polygon)
{
    for (std::size_t i = 1; i + 1 < polygon.size(); ++i) {
        mesh.triangles.emplace_back(polygon[0], polygon[i], polygon[i + 1]);
    }
}

// ---- PLY ------------------------------------------------------------------------------------

enum class Scalar { int8, uint8, int16, uint16, int32, uint32, float32, float64 };

std::optional<Scalar> scalar_named(std::string_view name)
{
    if (name == "char" || name == "int8") return Scalar::int8;
    if (name == "uchar" || name == "uint8") return Scalar::uint8;
    if (name == "short" || name == "int16") return Scalar::int16;
    if (name == "ushort" || name == "uint16") return Scalar::uint16;
    if (name == "int" || name == "int32") return Scalar::int32;
    if (name == "uint" || name == "uint32") return Scalar::uint32;
    if (name == "float" || name == "float32") return Scalar::float32;
    if (name == "double" || name == "float64") return Scalar::float64;
    return std::nullopt;
}

std::size_t size_of(Scalar type)
{
    switch (type) {
    case Scalar::int8:
    case Scalar::uint8: return 1;
    case Scalar::int16:
    case Scalar::uint16: return 2;
    case Scalar::int32:
    case Scalar::uint32:
    case Scalar::float32: return 4;
    case Scalar::float64: return 8;
    }
    return 0;
}

bool is_integer(Scalar type)
{
    return type != Scalar::float32 && type != Scalar::float64;
}

// Whether an ascii word read as `value` is a valid value of `type`. Integers must be whole and in
// range: a list length of 1e30 would otherwise be cast to an integer it does not fit.
bool fits(Scalar type, double value)
{
    const auto within = [value](double low, double high) {
        return value >= low && value <= high && value == std::floor(value);
    };
    switch (type) {
    case Scalar::int8: return within(-128.0, 127.0);
    case Scalar::uint8: return within(0.0, 255.0);
    case Scalar::int16: return within(-32768.0, 32767.0);
    case Scalar::uint16: return within(0.0, 65535.0);
    case Scalar::int32: return within(-2147483648.0, 2147483647.0);
    case Scalar::uint32: return within(0.0, 4294967295.0);
    case Scalar::float32:
    case Scalar::float64: return true;  // NaN and Inf included: the vertex check names them
    }
    return false;
}

enum class Encoding { ascii, binary_little_endian, binary_big_endian };

struct Property {
    std::string name;
    bool is_list = false;
    Scalar type = Scalar::float32;       // of the value, or of each list entry
    Scalar count_type = Scalar::uint8;   // of a list's length
};

struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::vector<Property> properties;
};

struct Header {
    Encoding encoding = Encoding::ascii;
    std::vector<Element> elements;
    std::size_t data_start = 0;  // byte offset of the data
    std::size_t lines = 0;       // header lines, so that ascii data lines are numbered in the file
};

Header parse_ply_header(std::string_view text, const std::string& file)
{
    Header header;
    std::vector<std::string_view> words;
    std::size_t pos = 0;
    bool format_seen = false;
    while (true) {
        if (pos >= text.size()) throw Error(file, "PLY header has no end_header line");
        const std::size_t end = text.find('\n', pos);
        const std::string_view line = text.substr(pos, end == std::string_view::npos ? text.size() - pos : end - pos);
        pos = end == std::string_view::npos ? text.size() : end + 1;
        ++header.lines;
        const std::string where = file + ":" + std::to_string(header.lines);
        split_words(line, words);
        if (header.lines == 1) {
            if (words.size() != 1 || words[0] != "ply") throw Error(where, "not a PLY file (expected 'ply')");
            continue;
        }
        if (words.empty() || words[0] == "comment" || words[0] == "obj_info") continue;
        if (words[0] == "end_header") break;
        if (words[0] == "format") {
            if (format_seen) throw Error(where, "second format line");
            format_seen = true;
            if (words.size() != 3 || words[2] != "1.0") throw Error(where, "expected 'format <encoding> 1.0'");
            if (words[1] == "ascii") {
                header.encoding = Encoding::ascii;
            } else if (words[1] == "binary_little_endian") {
                header.encoding = Encoding::binary_little_endian;
            } else if (words[1] == "binary_big_endian") {
                header.encoding = Encoding::binary_big_endian;
            } else {
                throw Error(where, "unknown PLY encoding " + quote_word(words[1]));
            }
        } else if (words[0] == "element") {
            std::int64_t count = -1;
            if (words.size() != 3 || !parse_integer(words[2], count) || count < 0) {
                throw Error(where, "expected 'element <name> <count>'");
            }
            header.elements.push_back({std::string(words[1]), static_cast<std::uint64_t>(count), {}});
        } else if (words[0] == "property") {
            if (header.elements.empty()) throw Error(where, "property before any element");
            Property property;
            if (words.size() == 5 && words[1] == "list") {
                const auto count_type = scalar_named(words[2]);
                const auto type = scalar_named(words[3]);
                if (!count_type || !type) throw Error(where, "unknown type in list property " + quote_word(words[4]));
                if (!is_integer(*count_type)) {
                    throw Error(where, "list length type " + quote_word(words[2]) + " is not an integer");
                }
                property = {std::string(words[4]), true, *type, *count_type};
            } else if (words.size() == 3) {
                const auto type = scalar_named(words[1]);
                if (!type) throw Error(where, "unknown property type " + quote_word(words[1]));
                property = {std::string(words[2]), false, *type, Scalar::uint8};
            } else {
                throw Error(where, "malformed property line");
            }
            header.elements.back().properties.push_back(std::move(property));
        } else {
            throw Error(where, "unknown header line starting " + quote_word(words[0]));
        }
    }
    if (!format_seen) throw Error(file, "PLY header has no format line");
    header.data_start = pos;
    return header;
}

// Binary data: values in the file's byte order, no separators.
class BinarySource {
public:
    BinarySource(std::string_view data, bool swap_bytes, const std::string& file)
        : data_(data), swap_bytes_(swap_bytes), file_(file)
    {
    }

    // False when the data ends first.
    bool read(Scalar type, double& value)
    {
        const std::size_t size = size_of(type);
        if (size > data_.size() - pos_) return false;
        unsigned char bytes[8];
        std::memcpy(bytes, data_.data() + pos_, size);
        pos_ += size;
        if (swap_bytes_) std::reverse(bytes, bytes + size);
        value = decode(bytes, type);
        return true;
    }

    // Items of a fixed size (an element without lists) are skipped at once.
    static constexpr bool skips_fixed_size = true;

    // Skips `count` items of `size` bytes; false when the data ends first.
    bool skip(std::uint64_t count, std::size_t size)
    {
        const std::uint64_t left = data_.size() - pos_;
        if (size != 0 && count > left / size) return false;
        pos_ += static_cast<std::size_t>(count * size);
        return true;
    }

    std::string where() const { return file_; }
    // Bytes after the data are ignored: some writers end the file with a newline or padding.
    bool at_end() { return true; }

private:
    static double decode(const unsigned char* bytes, Scalar type)
    {
        const auto load = [bytes](auto value) {
            std::memcpy(&value, bytes, sizeof(value));
            return static_cast<double>(value);
        };
        switch (type) {
        case Scalar::int8: return load(std::int8_t{});
        case Scalar::uint8: return load(std::uint8_t{});
        case Scalar::int16: return load(std::int16_t{});
        case Scalar::uint16: return load(std::uint16_t{});
        case Scalar::int32: return load(std::int32_t{});
        case Scalar::uint32: return load(std::uint32_t{});
        case Scalar::float32: return load(float{});
        case Scalar::float64: return load(double{});
        }
        return 0.0;
    }

    std::string_view data_;
    std::size_t pos_ = 0;
    bool swap_bytes_;
    const std::string& file_;
};

// Ascii data: whitespace-separated words, not tied to lines (PLY does not tie items to lines).
class AsciiSource {
public:
    AsciiSource(std::string_view data, std::size_t first_line, const std::string& file)
        : data_(data), line_(first_line), word_line_(first_line), file_(file)
    {
    }

    // False when the data ends first; throws for a word that is not a number of the given type.
    bool read(Scalar type, double& value)
    {
        if (!next_word()) return false;
        if (!parse_double(word_, value)) throw Error(where(), quote_word(word_) + " is not a number");
        if (!fits(type, value)) {
            throw Error(where(), quote_word(word_) + " is not a value of the property's integer type");
        }
        return true;
    }

    // Ascii items have no fixed size: every value is read.
    static constexpr bool skips_fixed_size = false;

    // The line of the last word read: where a bad value is, or where the data ended too early.
    std::string where() const { return file_ + ":" + std::to_string(word_line_); }
    // Words after the last element are an error, as they are in the cloud reader: the header
    // miscounted something.
    bool at_end() { return !next_word(); }

private:
    bool next_word()
    {
        while (pos_ < data_.size() && std::isspace(static_cast<unsigned char>(data_[pos_]))) {
            if (data_[pos_] == '\n') ++line_;
            ++pos_;
        }
        if (pos_ == data_.size()) return false;
        const std::size_t start = pos_;
        while (pos_ < data_.size() && !std::isspace(static_cast<unsigned char>(data_[pos_]))) ++pos_;
        word_ = data_.substr(start, pos_ - start);
        word_line_ = line_;
        return true;
    }

    std::string_view data_;
    std::size_t pos_ = 0;
    std::size_t line_;       // of the next byte
    std::size_t word_line_;  // of word_
    std::string_view word_;
    const std::string& file_;
};

// Where the reader finds the mesh in the header's elements.
struct PlyLayout {
    std::size_t vertex = 0;                   // element index
    std::array<std::size_t, 3> xyz{};         // property indices of x, y, z in the vertex element
    std::size_t face = 0;                     // element index
    std::size_t indices = 0;                  // property index of the index list in the face element
};

PlyLayout find_layout(const Header& header, const std::string& file)
{
    PlyLayout layout;
    std::optional<std::size_t> vertex;
    std::optional<std::size_t> face;
    for (std::size_t e = 0; e < header.elements.size(); ++e) {
        const std::string& name = header.elements[e].name;
        if (name != "vertex" && name != "face") continue;
        std::optional<std::size_t>& found = name == "vertex" ? vertex : face;
        if (found) throw Error(file, "PLY header has two '" + name + "' elements");
        found = e;
    }
    if (!vertex) throw Error(file, "PLY header has no vertex element");
    if (!face || header.elements[*face].count == 0) throw Error(file, "no faces");
    layout.vertex = *vertex;
    layout.face = *face;

    const Element& vertices = header.elements[*vertex];
    if (vertices.count > max_vertices) {
        throw Error(file, std::to_string(vertices.count) + " vertices are more than a mesh can index");
    }
    const std::array<const char*, 3> axes = {"x", "y", "z"};
    for (std::size_t axis = 0; axis < 3; ++axis) {
        const auto found = std::find_if(vertices.properties.begin(), vertices.properties.end(),
                                        [&](const Property& property) { return property.name == axes[axis]; });
        if (found == vertices.properties.end()) throw Error(file, std::string("vertex element has no ") + axes[axis]);
        if (found->is_list) throw Error(file, std::string("vertex property ") + axes[axis] + " is a list");
        layout.xyz[axis] = static_cast<std::size_t>(found - vertices.properties.begin());
    }

    const Element& faces = header.elements[*face];
    const auto found = std::find_if(faces.properties.begin(), faces.properties.end(), [](const Property& property) {
        return property.name == "vertex_indices" || property.name == "vertex_index";
    });
    if (found == faces.properties.end()) throw Error(file, "face element has no vertex_indices list");
    if (!found->is_list || !is_integer(found->type)) {
        throw Error(file, "face property " + found->name + " is not a list of integers");
    }
    layout.indices = static_cast<std::size_t>(found - faces.properties.begin());
    return layout;
}

template <class Source>
TriangleMesh read_ply_data(const Header& header, const PlyLayout& layout, Source& source, std::size_t data_size)
{
    TriangleMesh mesh;
    const std::uint64_t vertex_count = header.elements[layout.vertex].count;
    // Counts come from the header, which may overstate them: a false count in a small file must not
    // reserve gigabytes. Six bytes a vertex is the least ascii data ("0 0 0\n") takes.
    mesh.vertices.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(vertex_count, data_size / 6)));
    std::vector<int> polygon;
    for (std::size_t e = 0; e < header.elements.size(); ++e) {
        const Element& element = header.elements[e];
        // Items without properties take no data, however many the header claims.
        if (element.properties.empty()) continue;
        const bool is_vertex = e == layout.vertex;
        const bool is_face = e == layout.face;
        const auto ends = [&](std::uint64_t item) {
            return Error(source.where(), "data ends in element '" + element.name + "' (item " + std::to_string(item) +
                                             " of " + std::to_string(element.count) + ")");
        };
        const bool has_lists = std::any_of(element.properties.begin(), element.properties.end(),
                                           [](const Property& property) { return property.is_list; });
        if constexpr (Source::skips_fixed_size) {
            if (!is_vertex && !is_face && !has_lists) {
                std::size_t size = 0;
                for (const Property& property : element.properties) size += size_of(property.type);
                if (!source.skip(element.count, size)) {
                    throw Error(source.where(), "data ends in element '" + element.name + "' (" +
                                                    std::to_string(element.count) + " items of " +
                                                    std::to_string(size) + " bytes)");
                }
                continue;
            }
        }
        double value = 0.0;
        std::array<double, 3> xyz{};
        for (std::uint64_t item = 0; item < element.count; ++item) {
            for (std::size_t p = 0; p < element.properties.size(); ++p) {
                const Property& property = element.properties[p];
                if (!property.is_list) {
                    if (!source.read(property.type, value)) throw ends(item);
                    if (is_vertex) {
                        for (std::size_t axis = 0; axis < 3; ++axis) {
                            if (p == layout.xyz[axis]) xyz[axis] = value;
                        }
                    }
                    continue;
                }
                if (!source.read(property.count_type, value)) throw ends(item);
                if (value < 0.0) {
                    throw Error(source.where(), "element '" + element.name + "' item " + std::to_string(item) +
                                                    " has a list of negative length");
                }
                const auto length = static_cast<std::uint64_t>(value);
                const bool is_indices = is_face && p == layout.indices;
                if (is_indices && length < 3) {
                    throw Error(source.where(), "face " + std::to_string(item) + " has " + std::to_string(length) +
                                                    " vertices (a face needs at least 3)");
                }
                if (is_indices) polygon.clear();
                for (std::uint64_t i = 0; i < length; ++i) {
                    if (!source.read(property.type, value)) throw ends(item);
                    if (!is_indices) continue;
                    if (value < 0.0 || value >= double(vertex_count)) {
                        throw Error(source.where(), "face " + std::to_string(item) + ": vertex index " +
                                                        std::to_string(static_cast<std::int64_t>(value)) +
                                                        " out of range (" + std::to_string(vertex_count) +
                                                        " vertices)");
                    }
                    polygon.push_back(static_cast<int>(value));
                }
                if (is_indices) add_polygon(mesh, polygon);
            }
            if (!is_vertex) continue;
            Eigen::Vector3f point;
            for (int axis = 0; axis < 3; ++axis) {
                if (const auto problem = to_coordinate(xyz[static_cast<std::size_t>(axis)], point[axis])) {
                    throw Error(source.where(), "vertex " + std::to_string(item) + ": " + *problem);
                }
            }
            mesh.vertices.push_back(point);
        }
    }
    if (!source.at_end()) throw Error(source.where(), "ascii data continues after the last element");
    return mesh;
}

TriangleMesh read_ply(std::string_view text, const std::string& file)
{
    const Header header = parse_ply_header(text, file);
    const PlyLayout layout = find_layout(header, file);
    const std::string_view data = text.substr(header.data_start);
    if (header.encoding == Encoding::ascii) {
        AsciiSource source(data, header.lines + 1, file);
        return read_ply_data(header, layout, source, data.size());
    }
    BinarySource source(data, header.encoding == Encoding::binary_big_endian, file);
    return read_ply_data(header, layout, source, data.size());
}

// ---- OBJ ------------------------------------------------------------------------------------

// One face corner, "v", "v/vt", "v//vn" or "v/vt/vn": the vertex is the part before the first
// slash. OBJ counts from 1, and a negative index counts back from the last vertex read so far.
int obj_vertex(std::string_view corner, std::size_t vertex_count, const std::string& where)
{
    const std::string_view index_text = corner.substr(0, corner.find('/'));
    std::int64_t index = 0;
    if (!parse_integer(index_text, index)) {
        throw Error(where, "face corner " + quote_word(corner) + " has no vertex index");
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
        split_words(line, words);
        if (words.empty()) continue;
        const std::string where = file + ":" + std::to_string(line_number);
        if (words[0] == "v") {
            // "v x y z", optionally followed by w or by a colour, which a mesh does not keep.
            if (words.size() < 4) throw Error(where, "vertex needs x y z");
            Eigen::Vector3f point;
            for (int axis = 0; axis < 3; ++axis) {
                const std::string_view word = words[static_cast<std::size_t>(axis) + 1];
                double value = 0.0;
                if (!parse_double(word, value)) throw Error(where, quote_word(word) + " is not a number");
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
        throw Error(file, "unknown extension " + quote_word(path.extension().string()) + " (expected .ply or .obj)");
    }
    const std::string bytes = read_text_file(path);
    return extension == ".ply" ? read_ply(bytes, file) : read_obj(bytes, file);
}

}  // namespace mfpc
