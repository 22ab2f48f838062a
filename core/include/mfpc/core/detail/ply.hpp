#pragma once

// Internal (not installed): the one PLY header parser and element-data cursor, shared by the
// point cloud reader (core/src/ply_format.cpp) and the triangle mesh reader (tools/simulation).
//
// PLY (Stanford polygon file format 1.0) is a text header naming elements and their properties,
// then the items of every element in header order, as ascii words or as binary values in little or
// big endian byte order. A reader walks all of it, elements it does not keep included, so that a
// truncated face list is caught like a truncated vertex list.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "mfpc/core/detail/scalar_type.hpp"
#include "mfpc/core/error.hpp"

namespace mfpc::detail {

enum class PlyFormat { ascii, binary_little_endian, binary_big_endian };

struct PlyProperty {
    std::string name;
    bool is_list = false;
    ScalarType type = ScalarType::float32;      // of the value, or of each list item
    ScalarType count_type = ScalarType::uint8;  // of a list's length
};

struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;
};

struct PlyHeader {
    PlyFormat format = PlyFormat::ascii;
    std::vector<PlyElement> elements;
    std::size_t data_start = 0;  // byte offset of the data in the file
    std::size_t line_count = 0;  // header lines, so that ascii data lines are numbered as in the file
};

// Parses the header at the start of `file` (the whole file); `where` names it in errors, which give
// the header line where one is at fault.
PlyHeader parse_ply_header(std::string_view file, const std::string& where);

// The position of the one element called `name`, or nothing; throws when the header has two.
std::optional<std::size_t> find_ply_element(const PlyHeader& header, std::string_view name, const std::string& where);

// Reads the data after the header, one value at a time, in the order the header gives: for each
// element, begin_element, then for each of its items begin_item and one call per property (value
// for a number, list_length then `length` values for a list, or skip); end after the last element.
// Every value is checked as it is read: binary data must not end early and list lengths must not
// be negative; ascii words must be numbers of the property's type (integers whole and in range).
// Errors name the file, and in ascii data the line of the last word read.
class PlyDataCursor {
public:
    // `file` is the whole file, header included; it and `header` must outlive the cursor.
    PlyDataCursor(const PlyHeader& header, std::string_view file, const std::string& where);

    // Starts the element at `element` in the header (elements in order, none left out). Binary data
    // must hold every item at its smallest size (lists empty): a header that claims more items than
    // the file can hold fails here, before a reader reserves memory for them.
    void begin_element(std::size_t element);

    // Passes over every item of the element begun: in binary data a fixed-size element (no lists)
    // at once, anything else value by value, so that bad words and truncated lists are still found.
    void skip_element();

    void begin_item(std::uint64_t item) { item_ = item; }

    // The next value: property `property` of the item (not a list), or the next item of list
    // `property`. Integer types give whole numbers, float32 gives exactly the float stored.
    double value(const PlyProperty& property)
    {
        if (!binary_) return word_value(property);
        const std::uint8_t* bytes = take(size_of(property.type));
        // Most of every binary read: floats in host byte order, and uchar colours.
        if (property.type == ScalarType::float32 && !swap_bytes_) {
            float value;
            std::memcpy(&value, bytes, sizeof(value));
            return value;
        }
        if (property.type == ScalarType::uint8) return bytes[0];
        return load_value(bytes, property.type);
    }

    // The length of list `property`, whose items follow.
    std::uint64_t list_length(const PlyProperty& property);

    // Passes over property `property` of the item, a number or a whole list.
    void skip(const PlyProperty& property);

    // After the last element: words left in ascii data are an error (the header miscounted
    // something); bytes after binary data are not (some writers end the file with padding).
    void end();

    // An error at the current place in the data, for what the caller finds wrong with a value.
    Error error(const std::string& reason) const;

private:
    // The next `size` bytes of binary data.
    const std::uint8_t* take(std::size_t size)
    {
        if (size > data_.size() - pos_) throw truncated();
        const auto* bytes = reinterpret_cast<const std::uint8_t*>(data_.data()) + pos_;
        pos_ += size;
        return bytes;
    }

    Error truncated() const;
    Error data_ends() const;
    // Out of line: it uses core's private loaders, the ones the PCD reader uses.
    double load_value(const std::uint8_t* bytes, ScalarType type) const;
    double word_value(const PlyProperty& property);
    std::int64_t word_integer(ScalarType type, const PlyProperty& property, const char* expected);
    bool read_word();  // false at the end of the data
    void next_word();  // throws at the end of the data
    Error bad_word(const PlyProperty& property, const char* expected) const;
    Error negative_length(const PlyProperty& property) const;

    const PlyHeader& header_;
    std::string_view data_;
    const std::string& where_;
    bool binary_;
    bool swap_bytes_;
    std::size_t pos_ = 0;
    std::size_t element_ = 0;
    std::uint64_t item_ = 0;
    // Ascii data only.
    std::string_view word_;  // the last word read
    std::size_t line_;       // of the next byte
    std::size_t word_line_;  // of word_
};

}  // namespace mfpc::detail
