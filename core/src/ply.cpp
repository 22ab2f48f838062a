#include "mfpc/core/detail/ply.hpp"

#include <bit>
#include <limits>
#include <utility>

#include "cloud_format.hpp"
#include "mfpc/core/detail/text_parse.hpp"

namespace mfpc::detail {

static_assert(std::endian::native == std::endian::little,
              "the PLY reader swaps bytes for binary_big_endian assuming a little-endian host");

namespace {

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

// What an ascii word of an integer type must be, for "'300' is not a uchar".
const char* integer_named(ScalarType type)
{
    switch (type) {
    case ScalarType::int8: return "a char";
    case ScalarType::uint8: return "a uchar";
    case ScalarType::int16: return "a short";
    case ScalarType::uint16: return "a ushort";
    case ScalarType::int32: return "an int";
    case ScalarType::uint32: return "a uint";
    case ScalarType::int64: return "an int64";
    case ScalarType::uint64: return "a uint64";
    case ScalarType::float32:
    case ScalarType::float64: break;
    }
    return "an integer";
}

template <typename T>
bool within(std::int64_t value)
{
    return value >= std::int64_t(std::numeric_limits<T>::min()) && value <= std::int64_t(std::numeric_limits<T>::max());
}

// Whether `value` is in the range of integer `type`.
bool fits(ScalarType type, std::int64_t value)
{
    switch (type) {
    case ScalarType::int8: return within<std::int8_t>(value);
    case ScalarType::uint8: return within<std::uint8_t>(value);
    case ScalarType::int16: return within<std::int16_t>(value);
    case ScalarType::uint16: return within<std::uint16_t>(value);
    case ScalarType::int32: return within<std::int32_t>(value);
    case ScalarType::uint32: return within<std::uint32_t>(value);
    case ScalarType::int64: return true;  // parse_signed has checked that much
    case ScalarType::uint64: return value >= 0;
    case ScalarType::float32:
    case ScalarType::float64: break;
    }
    return false;
}

}  // namespace

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
    header.line_count = line_number;
    return header;
}

std::optional<std::size_t> find_ply_element(const PlyHeader& header, std::string_view name, const std::string& where)
{
    std::optional<std::size_t> found;
    for (std::size_t e = 0; e < header.elements.size(); ++e) {
        if (header.elements[e].name != name) continue;
        if (found) throw Error(where, "header has two " + std::string(name) + " elements");
        found = e;
    }
    return found;
}

PlyDataCursor::PlyDataCursor(const PlyHeader& header, std::string_view file, const std::string& where)
    : header_(header),
      data_(file.substr(header.data_start)),
      where_(where),
      binary_(header.format != PlyFormat::ascii),
      swap_bytes_(header.format == PlyFormat::binary_big_endian),
      line_(header.line_count + 1),
      word_line_(header.line_count + 1)
{
}

// Inline: ascii data spends most of its time here, one call a word.
inline bool PlyDataCursor::read_word()
{
    // Items are not tied to lines: PLY separates every value by white space, line breaks included.
    const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
    while (pos_ < data_.size() && is_space(data_[pos_])) {
        if (data_[pos_] == '\n') ++line_;
        ++pos_;
    }
    if (pos_ == data_.size()) return false;
    const std::size_t start = pos_;
    while (pos_ < data_.size() && !is_space(data_[pos_])) ++pos_;
    word_ = data_.substr(start, pos_ - start);
    word_line_ = line_;
    return true;
}

inline void PlyDataCursor::next_word()
{
    if (!read_word()) throw data_ends();
}

inline std::int64_t PlyDataCursor::word_integer(ScalarType type, const PlyProperty& property, const char* expected)
{
    next_word();
    std::int64_t value = 0;
    if (!parse_signed(word_, value) || !fits(type, value)) throw bad_word(property, expected);
    return value;
}

double PlyDataCursor::word_value(const PlyProperty& property)
{
    const ScalarType type = property.type;
    if (is_integer(type)) return static_cast<double>(word_integer(type, property, integer_named(type)));
    next_word();
    if (type == ScalarType::float32) {
        // Parsed as a float, not as a double rounded to float: that could round twice.
        float value = 0;
        if (!parse_float(word_, value)) throw bad_word(property, "a number");
        return value;
    }
    double value = 0;
    if (!parse_double(word_, value)) throw bad_word(property, "a number");
    return value;
}

Error PlyDataCursor::data_ends() const
{
    const PlyElement& element = header_.elements[element_];
    return error("ascii data ends in element '" + element.name + "' (item " + std::to_string(item_) + " of " +
                 std::to_string(element.count) + ")");
}

void PlyDataCursor::begin_element(std::size_t element)
{
    element_ = element;
    item_ = 0;
    if (!binary_) return;
    const PlyElement& current = header_.elements[element];
    std::size_t min_size = 0;
    for (const PlyProperty& property : current.properties) {
        min_size += size_of(property.is_list ? property.count_type : property.type);
    }
    const auto min_total = checked_product(current.count, min_size);
    if (!min_total || *min_total > data_.size() - pos_) {
        throw Error(where_, "binary data is truncated: element '" + current.name + "' has " +
                                std::to_string(current.count) + " items of at least " + std::to_string(min_size) +
                                " bytes, " + std::to_string(data_.size() - pos_) + " bytes remain");
    }
}

void PlyDataCursor::skip_element()
{
    const PlyElement& element = header_.elements[element_];
    // Items without properties take no data, however many the header claims.
    if (element.properties.empty()) return;
    bool fixed_size = binary_;
    std::size_t size = 0;
    for (const PlyProperty& property : element.properties) {
        fixed_size = fixed_size && !property.is_list;
        size += size_of(property.type);
    }
    if (fixed_size) {
        // begin_element has checked that the data holds them.
        pos_ += static_cast<std::size_t>(element.count) * size;
        return;
    }
    for (std::uint64_t item = 0; item < element.count; ++item) {
        begin_item(item);
        for (const PlyProperty& property : element.properties) skip(property);
    }
}

std::uint64_t PlyDataCursor::list_length(const PlyProperty& property)
{
    if (!binary_) {
        const std::int64_t length = word_integer(property.count_type, property, "a list length");
        if (length < 0) throw negative_length(property);
        return static_cast<std::uint64_t>(length);
    }
    std::uint64_t length = 0;
    if (!load_as_count(take(size_of(property.count_type)), property.count_type, swap_bytes_, length)) {
        throw negative_length(property);
    }
    return length;
}

void PlyDataCursor::skip(const PlyProperty& property)
{
    if (!property.is_list) {
        if (binary_) {
            take(size_of(property.type));
        } else {
            word_value(property);
        }
        return;
    }
    const std::uint64_t length = list_length(property);
    if (binary_) {
        const auto size = checked_product(length, size_of(property.type));
        if (!size) throw truncated();
        take(*size);
        return;
    }
    for (std::uint64_t i = 0; i < length; ++i) word_value(property);
}

void PlyDataCursor::end()
{
    if (!binary_ && read_word()) throw error("ascii data continues after the last element with " + quoted(word_));
}

Error PlyDataCursor::error(const std::string& reason) const
{
    if (binary_) return Error(where_, reason);
    return Error(where_, "line " + std::to_string(word_line_) + ": " + reason);
}

Error PlyDataCursor::truncated() const
{
    const PlyElement& element = header_.elements[element_];
    return Error(where_, "binary data is truncated in element '" + element.name + "' (item " + std::to_string(item_) +
                             " of " + std::to_string(element.count) + ")");
}

double PlyDataCursor::load_value(const std::uint8_t* bytes, ScalarType type) const
{
    return load_as_double(bytes, type, swap_bytes_);
}

Error PlyDataCursor::bad_word(const PlyProperty& property, const char* expected) const
{
    return error("element '" + header_.elements[element_].name + "' item " + std::to_string(item_) + ": " +
                 quoted(word_) + " is not " + expected + " (property " + property.name + ")");
}

Error PlyDataCursor::negative_length(const PlyProperty& property) const
{
    return error("element '" + header_.elements[element_].name + "' item " + std::to_string(item_) +
                 " has a negative length for list " + property.name);
}

}  // namespace mfpc::detail
