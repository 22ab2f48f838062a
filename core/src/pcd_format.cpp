// PCD (Point Cloud Data, PCL's format, version 0.7): header keywords VERSION FIELDS SIZE TYPE COUNT
// WIDTH HEIGHT VIEWPOINT POINTS DATA, then the points as ascii rows, binary records (array of
// structures) or one LZF block holding the fields one after another (structure of arrays).
//
// Bytes after binary or binary_compressed data are ignored, as PCL ignores them: older PCL versions
// padded the files they wrote (the shared scene has 3901 zero bytes after its compressed block).
// Ascii rows beyond POINTS are an error: there the header and the data plainly disagree.
//
// Over 600 lines on purpose: one format. The three encodings are read through one header parser
// and one field layout, and the writer mirrors the reader's layout rules (organized rows, packed
// colour); kept together so that what is read and what is written cannot drift apart.

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cstring>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cloud_format.hpp"
#include "lzf.hpp"
#include "mfpc/core/error.hpp"

namespace mfpc::detail {

namespace {

constexpr std::uint64_t max_values_per_field = 1'000'000;  // far above any real descriptor (ESF: 640)
constexpr std::uint32_t opaque_alpha = 0xff000000u;         // PCL's PointXYZRGB writes alpha 255

struct PcdField {
    std::string name;
    std::size_t size = 0;   // bytes of one value
    std::size_t count = 1;  // values per point
    ScalarType type = ScalarType::float32;
    std::size_t offset = 0;       // bytes before it in a binary record
    std::size_t first_value = 0;  // values before it in an ascii row

    std::size_t bytes() const { return size * count; }
};

struct PcdHeader {
    std::vector<PcdField> fields;
    std::uint32_t width = 0;
    std::uint32_t height = 1;
    std::size_t points = 0;
    std::size_t point_size = 0;        // bytes of one binary record
    std::size_t values_per_point = 0;  // values in one ascii row
    CloudEncoding encoding = CloudEncoding::ascii;
    std::size_t data_start = 0;  // byte offset of the data in the file
    std::size_t header_lines = 0;
};

// Positions in PcdHeader::fields of the fields the reader turns into the cloud.
struct PcdLayout {
    std::size_t x = 0;
    std::size_t y = 0;
    std::size_t z = 0;
    std::optional<std::array<std::size_t, 3>> normal;
    std::optional<std::size_t> color;
};

ScalarType pcd_scalar_type(std::string_view type, std::uint64_t size, const std::string& field, const std::string& where)
{
    if (type.size() != 1 || (type[0] != 'I' && type[0] != 'U' && type[0] != 'F')) {
        throw Error(where, "field " + field + " has unknown TYPE " + quoted(type) + " (expected I, U or F)");
    }
    const char kind = type[0];
    if (kind == 'F' && size == 4) return ScalarType::float32;
    if (kind == 'F' && size == 8) return ScalarType::float64;
    if (kind == 'I' && size == 1) return ScalarType::int8;
    if (kind == 'I' && size == 2) return ScalarType::int16;
    if (kind == 'I' && size == 4) return ScalarType::int32;
    if (kind == 'I' && size == 8) return ScalarType::int64;
    if (kind == 'U' && size == 1) return ScalarType::uint8;
    if (kind == 'U' && size == 2) return ScalarType::uint16;
    if (kind == 'U' && size == 4) return ScalarType::uint32;
    if (kind == 'U' && size == 8) return ScalarType::uint64;
    throw Error(where, "field " + field + " has TYPE " + std::string(type) + " with SIZE " + std::to_string(size) +
                           ", which is not a supported number type (I/U: 1 2 4 8, F: 4 8)");
}

PcdHeader parse_pcd_header(std::string_view text, const std::string& where)
{
    std::optional<std::vector<std::string_view>> names, sizes, types, counts;
    std::optional<std::uint64_t> width, height, points;
    bool version_seen = false;
    bool viewpoint_seen = false;
    std::optional<CloudEncoding> encoding;

    PcdHeader header;
    std::vector<std::string_view> tokens;
    std::size_t pos = 0;
    std::size_t line_number = 0;
    while (!encoding) {
        if (pos >= text.size()) {
            throw Error(where, line_number == 0 ? std::string("file is empty") : "header has no DATA line");
        }
        const std::size_t end = text.find('\n', pos);
        const std::string_view line = text.substr(pos, end == std::string_view::npos ? std::string_view::npos : end - pos);
        pos = end == std::string_view::npos ? text.size() : end + 1;
        ++line_number;
        split_words(line, tokens);
        if (tokens.empty() || tokens[0].front() == '#') continue;

        const std::string at_line = "line " + std::to_string(line_number) + ": ";
        const std::string_view keyword = tokens[0];
        const std::vector<std::string_view> values(tokens.begin() + 1, tokens.end());
        const auto once = [&](bool seen) {
            if (seen) throw Error(where, at_line + "second " + std::string(keyword) + " line");
        };
        const auto list = [&](std::optional<std::vector<std::string_view>>& target) {
            once(target.has_value());
            if (values.empty()) throw Error(where, at_line + std::string(keyword) + " has no values");
            target = values;
        };
        const auto number = [&](std::optional<std::uint64_t>& target, std::uint64_t largest) {
            once(target.has_value());
            std::uint64_t value = 0;
            if (values.size() != 1 || !parse_unsigned(values[0], value)) {
                throw Error(where, at_line + std::string(keyword) + " needs one non-negative integer, got " + quoted(line));
            }
            if (value > largest) {
                throw Error(where, at_line + std::string(keyword) + " " + std::to_string(value) +
                                       " is out of range (at most " + std::to_string(largest) + ")");
            }
            target = value;
        };

        constexpr std::uint64_t largest_side = std::numeric_limits<std::uint32_t>::max();
        if (keyword == "VERSION") {
            once(version_seen);
            version_seen = true;
            const bool known = values.size() == 1 && (values[0] == "0.7" || values[0] == ".7" || values[0] == "0.6" ||
                                                      values[0] == ".6" || values[0] == "0.5" || values[0] == ".5");
            if (!known) throw Error(where, at_line + "unsupported VERSION " + quoted(line) + " (expected 0.7)");
        } else if (keyword == "FIELDS" || keyword == "COLUMNS") {
            list(names);
        } else if (keyword == "SIZE") {
            list(sizes);
        } else if (keyword == "TYPE") {
            list(types);
        } else if (keyword == "COUNT") {
            list(counts);
        } else if (keyword == "WIDTH") {
            number(width, largest_side);
        } else if (keyword == "HEIGHT") {
            number(height, largest_side);
        } else if (keyword == "POINTS") {
            number(points, std::numeric_limits<std::uint64_t>::max());
        } else if (keyword == "VIEWPOINT") {
            once(viewpoint_seen);
            viewpoint_seen = true;
            if (values.size() != 7) {
                throw Error(where, at_line + "VIEWPOINT needs 7 values (tx ty tz qw qx qy qz), got " +
                                       std::to_string(values.size()));
            }
        } else if (keyword == "DATA") {
            if (values.size() != 1) throw Error(where, at_line + "DATA needs one value, got " + quoted(line));
            if (values[0] == "ascii") {
                encoding = CloudEncoding::ascii;
            } else if (values[0] == "binary") {
                encoding = CloudEncoding::binary;
            } else if (values[0] == "binary_compressed") {
                encoding = CloudEncoding::binary_compressed;
            } else {
                throw Error(where, at_line + "unknown DATA encoding " + quoted(values[0]) +
                                       " (expected ascii, binary or binary_compressed)");
            }
        } else {
            throw Error(where, at_line + "unknown header line " + quoted(line));
        }
    }
    header.encoding = *encoding;
    header.data_start = pos;
    header.header_lines = line_number;

    if (!names) throw Error(where, "header has no FIELDS line");
    if (!sizes) throw Error(where, "header has no SIZE line");
    if (!types) throw Error(where, "header has no TYPE line");
    if (!width) throw Error(where, "header has no WIDTH line");
    const std::size_t field_count = names->size();
    const auto same_length = [&](const std::vector<std::string_view>& values, const char* keyword) {
        if (values.size() != field_count) {
            throw Error(where, std::string(keyword) + " has " + std::to_string(values.size()) + " values for " +
                                   std::to_string(field_count) + " FIELDS");
        }
    };
    same_length(*sizes, "SIZE");
    same_length(*types, "TYPE");
    if (counts) same_length(*counts, "COUNT");

    for (std::size_t f = 0; f < field_count; ++f) {
        PcdField field;
        field.name = std::string((*names)[f]);
        std::uint64_t size = 0;
        if (!parse_unsigned((*sizes)[f], size)) {
            throw Error(where, "field " + field.name + " has SIZE " + quoted((*sizes)[f]) + ", not a number");
        }
        field.type = pcd_scalar_type((*types)[f], size, field.name, where);
        field.size = size_of(field.type);
        if (counts) {
            std::uint64_t count = 0;
            if (!parse_unsigned((*counts)[f], count) || count == 0 || count > max_values_per_field) {
                throw Error(where, "field " + field.name + " has COUNT " + quoted((*counts)[f]) + " (expected 1 to " +
                                       std::to_string(max_values_per_field) + ")");
            }
            field.count = count;
        }
        field.offset = header.point_size;
        field.first_value = header.values_per_point;
        header.point_size += field.bytes();
        header.values_per_point += field.count;
        header.fields.push_back(std::move(field));
    }

    header.width = static_cast<std::uint32_t>(*width);
    header.height = static_cast<std::uint32_t>(height.value_or(1));
    const std::uint64_t grid = std::uint64_t(header.width) * header.height;
    if (points && *points != grid) {
        throw Error(where, "POINTS " + std::to_string(*points) + " does not match WIDTH x HEIGHT = " +
                               std::to_string(header.width) + " x " + std::to_string(header.height) + " = " +
                               std::to_string(grid));
    }
    // source_index is uint32: a larger cloud could not say where its points came from.
    if (grid > std::numeric_limits<std::uint32_t>::max()) {
        throw Error(where, "WIDTH x HEIGHT = " + std::to_string(grid) + " points is more than 4294967295");
    }
    header.points = static_cast<std::size_t>(grid);
    return header;
}

PcdLayout find_layout(const PcdHeader& header, const std::string& where)
{
    const auto find = [&](std::string_view name) -> std::optional<std::size_t> {
        std::optional<std::size_t> found;
        for (std::size_t f = 0; f < header.fields.size(); ++f) {
            if (header.fields[f].name != name) continue;
            if (found) throw Error(where, "field " + std::string(name) + " appears twice in FIELDS");
            found = f;
        }
        return found;
    };
    const auto single = [&](std::size_t f) {
        const PcdField& field = header.fields[f];
        if (field.count != 1) {
            throw Error(where, "field " + field.name + " has COUNT " + std::to_string(field.count) + ", expected 1");
        }
        return f;
    };
    std::string all_names;
    for (const PcdField& field : header.fields) all_names += (all_names.empty() ? "" : " ") + field.name;

    PcdLayout layout;
    const char* axes[3] = {"x", "y", "z"};
    std::size_t* targets[3] = {&layout.x, &layout.y, &layout.z};
    for (int axis = 0; axis < 3; ++axis) {
        const auto f = find(axes[axis]);
        if (!f) throw Error(where, std::string("no ") + axes[axis] + " field (FIELDS " + all_names + ")");
        *targets[axis] = single(*f);
    }

    // PCL spells the normal normal_x normal_y normal_z; some tools write nx ny nz. Either is read,
    // in full, and not both.
    const std::array<std::optional<std::size_t>, 3> pcl_normal = {find("normal_x"), find("normal_y"), find("normal_z")};
    const std::array<std::optional<std::size_t>, 3> short_normal = {find("nx"), find("ny"), find("nz")};
    const auto count = [](const std::array<std::optional<std::size_t>, 3>& fields) {
        return std::count_if(fields.begin(), fields.end(), [](const auto& f) { return f.has_value(); });
    };
    if (count(pcl_normal) != 0 && count(short_normal) != 0) {
        throw Error(where, "normals given both as normal_x normal_y normal_z and as nx ny nz (FIELDS " + all_names + ")");
    }
    const auto& normal = count(short_normal) != 0 ? short_normal : pcl_normal;
    if (count(normal) == 3) {
        layout.normal = std::array<std::size_t, 3>{single(*normal[0]), single(*normal[1]), single(*normal[2])};
    } else if (count(normal) != 0) {
        throw Error(where, "normals need all of normal_x normal_y normal_z (or nx ny nz) (FIELDS " + all_names + ")");
    }

    const auto rgb = find("rgb");
    const auto rgba = find("rgba");
    if (rgb && rgba) throw Error(where, "both rgb and rgba fields; expected one");
    if (rgb || rgba) {
        const std::size_t f = single(rgb ? *rgb : *rgba);
        if (header.fields[f].size != 4) {
            throw Error(where, "field " + header.fields[f].name + " has SIZE " + std::to_string(header.fields[f].size) +
                                   ", expected 4 (packed 0xAARRGGBB)");
        }
        layout.color = f;
    }
    return layout;
}

Rgb unpack_color(std::uint32_t bits)
{
    return Rgb{static_cast<std::uint8_t>(bits >> 16), static_cast<std::uint8_t>(bits >> 8),
               static_cast<std::uint8_t>(bits)};
}

// Where one field's values lie in decoded binary data: value i at first + i * stride.
struct FieldAccess {
    const std::uint8_t* first = nullptr;
    std::size_t stride = 0;
    ScalarType type = ScalarType::float32;

    const std::uint8_t* at(std::size_t i) const { return first + i * stride; }
    float as_float(std::size_t i) const { return load_as_float(at(i), type, false); }
};

// The zero counter for an organized file's builder (see FiniteCloudBuilder), none for a list.
std::size_t* organized_zeros(const PcdHeader& header, std::size_t& zero_points)
{
    return header.height > 1 ? &zero_points : nullptr;
}

// Keeps the finite points of binary data. `by_field` is true for the structure-of-arrays order of
// binary_compressed (every x, then every y, ...), false for records (x y z ... of point 0, then 1).
PointCloud gather_binary(const PcdHeader& header, const PcdLayout& layout, const std::uint8_t* data, bool by_field,
                         std::size_t& zero_points, const std::string& where)
{
    const auto access = [&](std::size_t f) {
        const PcdField& field = header.fields[f];
        // In structure-of-arrays order a field's block starts after the blocks of the fields
        // before it, each `points` times the record bytes of that field.
        return by_field ? FieldAccess{data + header.points * field.offset, field.bytes(), field.type}
                        : FieldAccess{data + field.offset, header.point_size, field.type};
    };
    const FieldAccess x = access(layout.x);
    const FieldAccess y = access(layout.y);
    const FieldAccess z = access(layout.z);
    std::array<FieldAccess, 3> normal{};
    if (layout.normal) {
        for (int axis = 0; axis < 3; ++axis) normal[axis] = access((*layout.normal)[axis]);
    }
    FieldAccess color{};
    if (layout.color) color = access(*layout.color);

    FiniteCloudBuilder builder(layout.normal.has_value(), layout.color.has_value(), header.points,
                               organized_zeros(header, zero_points));
    const Point no_normal = Point::Zero();
    for (std::size_t i = 0; i < header.points; ++i) {
        const Point point(x.as_float(i), y.as_float(i), z.as_float(i));
        const Point normal_value =
            layout.normal ? Point(normal[0].as_float(i), normal[1].as_float(i), normal[2].as_float(i)) : no_normal;
        const Rgb color_value = layout.color ? unpack_color(load_bits32(color.at(i))) : Rgb{};
        builder.add(static_cast<std::uint32_t>(i), point, normal_value, color_value);
    }
    return builder.finish(header.width, header.height, header.points, where);
}

PointCloud read_pcd_binary(const PcdHeader& header, const PcdLayout& layout, std::span<const std::uint8_t> data,
                               std::size_t& zero_points,
                           const std::string& where)
{
    const auto needed = checked_product(header.points, header.point_size);
    if (!needed || *needed > data.size()) {
        throw Error(where, "binary data is truncated: " + std::to_string(data.size()) + " bytes for " +
                               std::to_string(header.points) + " points of " + std::to_string(header.point_size) +
                               " bytes" + (needed ? " (" + std::to_string(*needed) + " needed)" : std::string()));
    }
    return gather_binary(header, layout, data.data(), false, zero_points, where);
}

PointCloud read_pcd_compressed(const PcdHeader& header, const PcdLayout& layout, std::span<const std::uint8_t> data,
                               std::size_t& zero_points,
                               const std::string& where)
{
    if (data.size() < 8) {
        throw Error(where, "compressed block is truncated: " + std::to_string(data.size()) +
                               " bytes where its two 4-byte sizes should be");
    }
    const std::uint32_t compressed_size = load_bits32(data.data());
    const std::uint32_t uncompressed_size = load_bits32(data.data() + 4);
    const std::span<const std::uint8_t> block = data.subspan(8);
    if (compressed_size > block.size()) {
        throw Error(where, "compressed block is truncated: " + std::to_string(block.size()) + " of " +
                               std::to_string(compressed_size) + " bytes present");
    }
    const auto needed = checked_product(header.points, header.point_size);
    if (!needed || *needed != uncompressed_size) {
        throw Error(where, "compressed block announces " + std::to_string(uncompressed_size) + " bytes, but " +
                               std::to_string(header.points) + " points of " + std::to_string(header.point_size) +
                               " bytes need " + (needed ? std::to_string(*needed) : std::string("more")));
    }
    // One LZF back-reference of 3 bytes yields at most 264, so no valid block expands more than 88
    // times; refusing that before allocating stops a forged size from claiming gigabytes.
    constexpr std::uint64_t max_expansion = 88;
    if (std::uint64_t(uncompressed_size) > max_expansion * compressed_size) {
        throw Error(where, "compressed data is corrupt (" + std::to_string(compressed_size) +
                               " bytes cannot decompress to the " + std::to_string(uncompressed_size) + " announced)");
    }
    // Not value-initialised: zeroing gigabytes that a corrupt block claims would cost seconds
    // before the decoder finds the fault. Untouched pages cost nothing, so time and memory follow
    // the bytes actually decoded, and every byte is written before it is read (or the block is
    // refused).
    const std::unique_ptr<std::uint8_t[]> decoded(new std::uint8_t[uncompressed_size]);
    lzf_decompress(block.first(compressed_size), std::span<std::uint8_t>(decoded.get(), uncompressed_size), where);
    return gather_binary(header, layout, decoded.get(), true, zero_points, where);
}

PointCloud read_pcd_ascii(const PcdHeader& header, const PcdLayout& layout, std::string_view text,
                          std::size_t& zero_points, const std::string& where)
{
    FiniteCloudBuilder builder(layout.normal.has_value(), layout.color.has_value(),
                               std::min(header.points, max_text_rows(text.size(), header.values_per_point)),
                               organized_zeros(header, zero_points));
    std::vector<std::string_view> tokens;
    tokens.reserve(header.values_per_point);
    std::size_t line_number = header.header_lines;
    std::string at_line;

    const auto value_of = [&](std::size_t f) -> float {
        const PcdField& field = header.fields[f];
        const std::string_view token = tokens[field.first_value];
        bool parsed = false;
        float value = 0;
        if (field.type == ScalarType::float32) {
            parsed = parse_float(token, value);
        } else {
            double wide = 0;
            parsed = parse_double(token, wide);
            value = narrow_to_float(wide);
        }
        if (!parsed) {
            throw Error(where, at_line + quoted(token) + " is not a number (field " + field.name + ")");
        }
        return value;
    };
    // PCL 1.13 writes the rgb field in ascii as the unsigned integer of its packed word (and
    // declares it U); older writers wrote the float that word spells (declared F). Both are read.
    const auto color_of = [&](std::size_t f) -> Rgb {
        const PcdField& field = header.fields[f];
        const std::string_view token = tokens[field.first_value];
        std::uint64_t unsigned_value = 0;
        std::int64_t signed_value = 0;
        float float_value = 0;
        if (parse_unsigned(token, unsigned_value) && unsigned_value <= std::numeric_limits<std::uint32_t>::max()) {
            return unpack_color(static_cast<std::uint32_t>(unsigned_value));
        }
        if (parse_signed(token, signed_value) && signed_value >= std::numeric_limits<std::int32_t>::min()) {
            return unpack_color(static_cast<std::uint32_t>(signed_value));
        }
        if (field.type == ScalarType::float32 && parse_float(token, float_value)) {
            return unpack_color(std::bit_cast<std::uint32_t>(float_value));
        }
        throw Error(where, at_line + quoted(token) + " is not a packed colour (field " + field.name + ")");
    };

    std::size_t row = 0;
    std::size_t pos = 0;
    const Point no_normal = Point::Zero();
    while (pos < text.size()) {
        const std::size_t end = text.find('\n', pos);
        const std::string_view line = text.substr(pos, end == std::string_view::npos ? std::string_view::npos : end - pos);
        pos = end == std::string_view::npos ? text.size() : end + 1;
        ++line_number;
        split_words(line, tokens);
        if (tokens.empty()) continue;
        at_line = "line " + std::to_string(line_number) + ": ";
        if (row == header.points) {
            throw Error(where, at_line + "ascii data has more rows than the " + std::to_string(header.points) +
                                   " points announced");
        }
        if (tokens.size() != header.values_per_point) {
            throw Error(where, at_line + std::to_string(tokens.size()) + " values, expected " +
                                   std::to_string(header.values_per_point));
        }
        const Point point(value_of(layout.x), value_of(layout.y), value_of(layout.z));
        const Point normal = layout.normal ? Point(value_of((*layout.normal)[0]), value_of((*layout.normal)[1]),
                                                   value_of((*layout.normal)[2]))
                                           : no_normal;
        const Rgb color = layout.color ? color_of(*layout.color) : Rgb{};
        builder.add(static_cast<std::uint32_t>(row), point, normal, color);
        ++row;
    }
    if (row < header.points) {
        throw Error(where, "ascii data ends after " + std::to_string(row) + " of " + std::to_string(header.points) +
                               " points");
    }
    return builder.finish(header.width, header.height, header.points, where);
}

// The order in which points go into the file: point indices, or `no_point` for a grid cell that
// holds none (written as NaN).
constexpr std::uint32_t no_point = std::numeric_limits<std::uint32_t>::max();

std::vector<std::uint32_t> organized_rows(const PointCloud& cloud, const std::string& where)
{
    const std::uint64_t grid = cloud.source_size();
    const std::string grid_name = std::to_string(cloud.width) + " x " + std::to_string(cloud.height);
    if (grid == 0) throw Error(where, "cannot write organized: the source grid is " + grid_name);
    if (grid >= no_point) throw Error(where, "cannot write organized: the source grid " + grid_name + " is too large");
    std::vector<std::uint32_t> rows(grid, no_point);
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        const std::uint32_t position = cloud.source_position(i);
        if (position >= grid) {
            throw Error(where, "cannot write organized: point " + std::to_string(i) + " has source position " +
                                   std::to_string(position) + ", outside the " + grid_name + " grid");
        }
        if (rows[position] != no_point) {
            throw Error(where, "cannot write organized: points " + std::to_string(rows[position]) + " and " +
                                   std::to_string(i) + " share source position " + std::to_string(position));
        }
        rows[position] = static_cast<std::uint32_t>(i);
    }
    return rows;
}

}  // namespace

PointCloud read_pcd(std::span<const std::uint8_t> file, const std::string& where, CloudReadReport& report)
{
    const std::string_view text(reinterpret_cast<const char*>(file.data()), file.size());
    const PcdHeader header = parse_pcd_header(text, where);
    const PcdLayout layout = find_layout(header, where);

    report.points_in = header.points;
    report.points_finite = 0;
    report.points_zero = 0;
    report.width = header.width;
    report.height = header.height;
    report.fields.clear();
    for (const PcdField& field : header.fields) report.fields.push_back(field.name);
    report.encoding = header.encoding;

    if (header.points == 0) {
        throw Error(where, "no points (WIDTH x HEIGHT is " + std::to_string(header.width) + " x " +
                               std::to_string(header.height) + ")");
    }
    PointCloud cloud;
    const std::span<const std::uint8_t> data = file.subspan(header.data_start);
    switch (header.encoding) {
    case CloudEncoding::ascii:
        cloud = read_pcd_ascii(header, layout, text.substr(header.data_start), report.points_zero, where);
        break;
    case CloudEncoding::binary: cloud = read_pcd_binary(header, layout, data, report.points_zero, where); break;
    case CloudEncoding::binary_compressed:
        cloud = read_pcd_compressed(header, layout, data, report.points_zero, where);
        break;
    }
    report.points_finite = cloud.size();
    return cloud;
}

std::string pcd_file_bytes(const PointCloud& cloud, const CloudWriteOptions& options, const std::string& where)
{
    std::vector<std::uint32_t> rows;
    std::uint32_t width = 0;
    std::uint32_t height = 1;
    if (options.organized) {
        rows = organized_rows(cloud, where);
        width = cloud.width;
        height = cloud.height;
    } else {
        if (cloud.size() >= no_point) throw Error(where, "too many points for one PCD file");
        rows.resize(cloud.size());
        for (std::size_t i = 0; i < rows.size(); ++i) rows[i] = static_cast<std::uint32_t>(i);
        width = static_cast<std::uint32_t>(cloud.size());
    }

    // Every field is 4 bytes: x y z, normal_x normal_y normal_z, and rgb as PCL 1.13 stores it: the
    // packed 0xAARRGGBB word, declared F in binary data and U in ascii data, where it is written as
    // that integer (PCL reads ascii F values as numbers, which would turn the word into garbage).
    const bool normals = cloud.has_normals();
    const bool colors = cloud.has_colors();
    const std::size_t field_count = 3 + (normals ? 3 : 0) + (colors ? 1 : 0);
    std::string out = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z";
    if (normals) out += " normal_x normal_y normal_z";
    if (colors) out += " rgb";
    const auto repeat = [&](const char* keyword, const char* value) {
        out += "\n";
        out += keyword;
        for (std::size_t f = 0; f < field_count; ++f) (out += ' ') += value;
    };
    repeat("SIZE", "4");
    out += "\nTYPE";
    for (std::size_t f = 0; f < field_count; ++f) {
        const bool color_field = colors && f + 1 == field_count;
        out += color_field && options.encoding == CloudEncoding::ascii ? " U" : " F";
    }
    repeat("COUNT", "1");
    out += "\nWIDTH " + std::to_string(width) + "\nHEIGHT " + std::to_string(height) +
           "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(rows.size()) + "\nDATA " +
           to_string(options.encoding) + "\n";

    const float nan = std::numeric_limits<float>::quiet_NaN();
    // The words of one row as 32-bit patterns, in FIELDS order.
    const auto row_words = [&](std::uint32_t index) {
        std::array<std::uint32_t, 7> words{};
        std::size_t w = 0;
        const auto put = [&](float value) { words[w++] = std::bit_cast<std::uint32_t>(value); };
        if (index == no_point) {
            for (std::size_t f = 0; f < 3 + (normals ? 3u : 0u); ++f) put(nan);
            if (colors) words[w++] = 0;
            return words;
        }
        const Point& point = cloud.points[index];
        put(point.x());
        put(point.y());
        put(point.z());
        if (normals) {
            const Point& normal = cloud.normals[index];
            put(normal.x());
            put(normal.y());
            put(normal.z());
        }
        if (colors) {
            const Rgb& color = cloud.colors[index];
            words[w++] = opaque_alpha | std::uint32_t(color.r) << 16 | std::uint32_t(color.g) << 8 | color.b;
        }
        return words;
    };

    const std::size_t point_size = 4 * field_count;
    switch (options.encoding) {
    case CloudEncoding::ascii: {
        out.reserve(out.size() + rows.size() * field_count * 12);
        for (const std::uint32_t index : rows) {
            const auto words = row_words(index);
            for (std::size_t f = 0; f < field_count; ++f) {
                if (f > 0) out += ' ';
                if (colors && f + 1 == field_count) {
                    char buffer[16];
                    const auto result = std::to_chars(buffer, buffer + sizeof(buffer), words[f]);
                    out.append(buffer, result.ptr);
                } else {
                    append_float(out, std::bit_cast<float>(words[f]));
                }
            }
            out += '\n';
        }
        break;
    }
    case CloudEncoding::binary: {
        const std::size_t start = out.size();
        out.resize(start + rows.size() * point_size);
        for (std::size_t r = 0; r < rows.size(); ++r) {
            const auto words = row_words(rows[r]);
            std::memcpy(out.data() + start + r * point_size, words.data(), point_size);
        }
        break;
    }
    case CloudEncoding::binary_compressed: {
        const std::size_t count = rows.size();
        if (count * point_size > std::numeric_limits<std::uint32_t>::max()) {
            throw Error(where, "too many points for binary_compressed (its block sizes are 32-bit)");
        }
        std::vector<std::uint8_t> by_field(count * point_size);
        for (std::size_t r = 0; r < count; ++r) {
            const auto words = row_words(rows[r]);
            for (std::size_t f = 0; f < field_count; ++f) {
                std::memcpy(by_field.data() + 4 * (f * count + r), &words[f], 4);
            }
        }
        const std::vector<std::uint8_t> block = lzf_compress(by_field);
        if (block.size() > std::numeric_limits<std::uint32_t>::max()) {
            throw Error(where, "compressed block is too large for binary_compressed (its sizes are 32-bit)");
        }
        const std::uint32_t sizes[2] = {static_cast<std::uint32_t>(block.size()),
                                        static_cast<std::uint32_t>(by_field.size())};
        out.append(reinterpret_cast<const char*>(sizes), sizeof(sizes));
        out.append(reinterpret_cast<const char*>(block.data()), block.size());
        break;
    }
    }
    return out;
}

}  // namespace mfpc::detail
