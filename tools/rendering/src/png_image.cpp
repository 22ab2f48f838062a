#include "mfpc/rendering/png_image.hpp"

#include <bit>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include <png.h>

#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

// libpng reports an error by calling a function that must not return. Throwing a C++ exception
// through libpng's C frames is not something libpng supports, so the error function copies the
// message here and longjmps back to the setjmp of one of the small `*_step` functions below. Those
// functions hold nothing with a destructor, so the jump skips no cleanup; whatever owns memory
// (the png structs, the row buffers, the streams) lives in their callers, which turn a failed step
// into mfpc::Error.
struct PngContext {
    char message[256] = {};
    std::ostream* out = nullptr;
    std::istream* in = nullptr;
};

PngContext& context_of_error(png_structp png) { return *static_cast<PngContext*>(png_get_error_ptr(png)); }
PngContext& context_of_io(png_structp png) { return *static_cast<PngContext*>(png_get_io_ptr(png)); }

void on_error(png_structp png, png_const_charp message)
{
    PngContext& context = context_of_error(png);
    std::snprintf(context.message, sizeof context.message, "%s", message != nullptr ? message : "unknown error");
    png_longjmp(png, 1);
}

// libpng's default prints warnings (an unknown chunk, a bad gamma value) to stderr, which would
// break the command line's one-line rule; none of them changes the pixels we read or write.
void on_warning(png_structp, png_const_charp) {}

void write_bytes(png_structp png, png_bytep data, std::size_t length)
{
    PngContext& context = context_of_io(png);
    bool written = false;
    try {
        context.out->write(reinterpret_cast<const char*>(data), std::streamsize(length));
        written = bool(*context.out);
    } catch (...) {
        written = false;
    }
    // Outside the catch block: longjmp must not leave a handler with a live exception.
    if (!written) png_error(png, "writing failed (disk full?)");
}

void flush_bytes(png_structp png)
{
    PngContext& context = context_of_io(png);
    bool flushed = false;
    try {
        context.out->flush();
        flushed = bool(*context.out);
    } catch (...) {
        flushed = false;
    }
    if (!flushed) png_error(png, "writing failed (disk full?)");
}

void read_bytes(png_structp png, png_bytep data, std::size_t length)
{
    PngContext& context = context_of_io(png);
    bool complete = false;
    try {
        context.in->read(reinterpret_cast<char*>(data), std::streamsize(length));
        complete = context.in->gcount() == std::streamsize(length);
    } catch (...) {
        complete = false;
    }
    if (!complete) png_error(png, "the file ends early (truncated)");
}

// The steps. Each returns false when libpng failed, the reason in the context.

bool write_step(png_structp png, png_infop info, png_uint_32 width, png_uint_32 height, int bit_depth,
                int color_type, png_bytepp rows)
{
    if (setjmp(png_jmpbuf(png))) return false;
    png_set_IHDR(png, info, width, height, bit_depth, color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    // PNG stores 16-bit samples big-endian; our buffers are in the machine's order.
    if (bit_depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
    png_write_image(png, rows);
    png_write_end(png, nullptr);
    return true;
}

struct Header {
    png_uint_32 width = 0;
    png_uint_32 height = 0;
    int bit_depth = 0;
    int color_type = 0;
    std::size_t row_bytes = 0;  // after the transforms
};

bool read_info_step(png_structp png, png_infop info, Header* header)
{
    if (setjmp(png_jmpbuf(png))) return false;
    png_set_sig_bytes(png, 8);
    png_read_info(png, info);
    png_get_IHDR(png, info, &header->width, &header->height, &header->bit_depth, &header->color_type, nullptr,
                 nullptr, nullptr);
    return true;
}

bool rgb_transforms_step(png_structp png, png_infop info, Header* header)
{
    if (setjmp(png_jmpbuf(png))) return false;
    png_set_expand(png);  // palette to rgb, grey below 8 bits to 8, tRNS to alpha
    png_set_strip_16(png);
    png_set_strip_alpha(png);
    if (header->color_type == PNG_COLOR_TYPE_GRAY || header->color_type == PNG_COLOR_TYPE_GRAY_ALPHA) {
        png_set_gray_to_rgb(png);
    }
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    header->row_bytes = png_get_rowbytes(png, info);
    return true;
}

bool gray_transforms_step(png_structp png, png_infop info, Header* header)
{
    if (setjmp(png_jmpbuf(png))) return false;
    if (header->bit_depth < 8) png_set_packing(png);  // one byte a sample, value unscaled
    png_set_strip_alpha(png);
    if (header->bit_depth == 16 && std::endian::native == std::endian::little) png_set_swap(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    header->row_bytes = png_get_rowbytes(png, info);
    return true;
}

bool read_rows_step(png_structp png, png_bytepp rows)
{
    if (setjmp(png_jmpbuf(png))) return false;
    png_read_image(png, rows);
    png_read_end(png, nullptr);
    return true;
}

struct WriteStructs {
    png_structp png = nullptr;
    png_infop info = nullptr;
    WriteStructs() = default;
    WriteStructs(const WriteStructs&) = delete;
    WriteStructs& operator=(const WriteStructs&) = delete;
    ~WriteStructs() { png_destroy_write_struct(&png, &info); }
};

struct ReadStructs {
    png_structp png = nullptr;
    png_infop info = nullptr;
    ReadStructs() = default;
    ReadStructs(const ReadStructs&) = delete;
    ReadStructs& operator=(const ReadStructs&) = delete;
    ~ReadStructs() { png_destroy_read_struct(&png, &info, nullptr); }
};

// The limits libpng itself applies to what it reads; checked before writing so that a file we
// write can always be read back.
constexpr std::uint32_t max_side = PNG_USER_WIDTH_MAX < PNG_USER_HEIGHT_MAX ? PNG_USER_WIDTH_MAX
                                                                            : PNG_USER_HEIGHT_MAX;
// Refuse to allocate for absurd headers (a 1,000,000 x 1,000,000 image is a valid header).
constexpr std::uint64_t max_pixels = std::uint64_t(1) << 28;

void check_size(const std::string& where, std::uint64_t width, std::uint64_t height)
{
    if (width == 0 || height == 0) {
        throw Error(where, "image size " + std::to_string(width) + "x" + std::to_string(height) + " is empty");
    }
    if (width > max_side || height > max_side || width * height > max_pixels) {
        throw Error(where, "image size " + std::to_string(width) + "x" + std::to_string(height) + " is too large");
    }
}

std::string encode_rows(const std::string& where, std::uint32_t width, std::uint32_t height, int bit_depth,
                        int color_type, const std::uint8_t* data, std::size_t row_bytes)
{
    std::ostringstream out;
    PngContext context;
    context.out = &out;
    WriteStructs structs;
    structs.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &context, on_error, on_warning);
    if (structs.png == nullptr) throw Error(where, "libpng cannot start (out of memory?)");
    structs.info = png_create_info_struct(structs.png);
    if (structs.info == nullptr) throw Error(where, "libpng cannot start (out of memory?)");
    png_set_write_fn(structs.png, &context, write_bytes, flush_bytes);
    std::vector<png_bytep> rows(height);
    // libpng's row type is not const, but writing only reads the rows.
    for (std::uint32_t y = 0; y < height; ++y) rows[y] = const_cast<png_bytep>(data + std::size_t(y) * row_bytes);
    if (!write_step(structs.png, structs.info, width, height, bit_depth, color_type, rows.data())) {
        throw Error(where, std::string("cannot write PNG: ") + context.message);
    }
    return std::move(out).str();
}

void write_bytes_atomically(const std::filesystem::path& path, const std::string& bytes)
{
    write_file_atomically(path, [&](std::ofstream& out) { out.write(bytes.data(), std::streamsize(bytes.size())); });
}

// libpng allocates a chunk's declared length before it reads the chunk, so a 79-byte file whose
// sPLT chunk claimed 1.6 GB took 1.6 GB (fuzz_png), whatever png_set_chunk_malloc_max said. Every
// chunk up to IEND must therefore lie within the file; `in` is left just after the signature.
void check_chunk_lengths(const std::string& where, std::ifstream& in, std::uintmax_t file_size)
{
    std::uintmax_t at = 8;
    while (at + 8 <= file_size) {
        unsigned char head[8] = {};
        in.seekg(std::streamoff(at));
        in.read(reinterpret_cast<char*>(head), sizeof head);
        if (in.gcount() != std::streamsize(sizeof head)) break;
        const std::uint32_t length = std::uint32_t(head[0]) << 24 | std::uint32_t(head[1]) << 16 |
                                     std::uint32_t(head[2]) << 8 | std::uint32_t(head[3]);
        if (at + 12 + std::uintmax_t(length) > file_size)
            throw Error(where, "the file ends early (truncated): the chunk at byte " + std::to_string(at) + " claims " +
                                   std::to_string(length) + " bytes, the file has " + std::to_string(file_size));
        if (std::memcmp(head + 4, "IEND", 4) == 0) break;
        at += 12 + std::uintmax_t(length);
    }
    in.clear();
    in.seekg(8);
}

// Opens the file, checks the signature and reads the header; `structs` and `in` must outlive the
// rest of the read, since libpng keeps pointers to the context.
Header open_png(const std::filesystem::path& path, std::ifstream& in, ReadStructs& structs, PngContext& context)
{
    const std::string where = path.string();
    std::error_code status_error;
    if (!std::filesystem::exists(path, status_error)) throw Error(where, "no such file");
    if (std::filesystem::is_directory(path, status_error)) throw Error(where, "is a directory");
    in.open(path, std::ios::binary);
    if (!in) throw Error(where, "cannot open (permissions?)");
    png_byte signature[8] = {};
    in.read(reinterpret_cast<char*>(signature), sizeof signature);
    if (in.gcount() != std::streamsize(sizeof signature) || png_sig_cmp(signature, 0, sizeof signature) != 0) {
        throw Error(where, "not a PNG file (bad signature)");
    }
    check_chunk_lengths(where, in, std::filesystem::file_size(path, status_error));
    context.in = &in;
    structs.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &context, on_error, on_warning);
    if (structs.png == nullptr) throw Error(where, "libpng cannot start (out of memory?)");
    structs.info = png_create_info_struct(structs.png);
    if (structs.info == nullptr) throw Error(where, "libpng cannot start (out of memory?)");
    png_set_read_fn(structs.png, &context, read_bytes);
    Header header;
    if (!read_info_step(structs.png, structs.info, &header)) {
        throw Error(where, std::string("not a valid PNG: ") + context.message);
    }
    check_size(where, header.width, header.height);
    return header;
}

void read_pixels(const std::string& where, ReadStructs& structs, const PngContext& context, std::uint8_t* data,
                 std::uint32_t height, std::size_t row_bytes)
{
    std::vector<png_bytep> rows(height);
    for (std::uint32_t y = 0; y < height; ++y) rows[y] = data + std::size_t(y) * row_bytes;
    if (!read_rows_step(structs.png, rows.data())) throw Error(where, std::string("not a valid PNG: ") + context.message);
}

}  // namespace

std::string png_file_bytes(const RgbImage& image, const std::string& where)
{
    check_size(where, image.width, image.height);
    const std::size_t expected = std::size_t(image.width) * image.height * 3;
    if (image.pixels.size() != expected) {
        throw Error(where, "image of " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                               " needs " + std::to_string(expected) + " bytes of rgb, has " +
                               std::to_string(image.pixels.size()));
    }
    return encode_rows(where, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, image.pixels.data(),
                       std::size_t(image.width) * 3);
}

std::string png_gray16_file_bytes(std::uint32_t width, std::uint32_t height, std::span<const std::uint16_t> values,
                                  const std::string& where)
{
    check_size(where, width, height);
    const std::size_t expected = std::size_t(width) * height;
    if (values.size() != expected) {
        throw Error(where, "image of " + std::to_string(width) + "x" + std::to_string(height) + " needs " +
                               std::to_string(expected) + " values, has " + std::to_string(values.size()));
    }
    return encode_rows(where, width, height, 16, PNG_COLOR_TYPE_GRAY, reinterpret_cast<const std::uint8_t*>(values.data()),
                       std::size_t(width) * 2);
}

void write_png(const std::filesystem::path& path, const RgbImage& image)
{
    write_bytes_atomically(path, png_file_bytes(image, path.string()));
}

void write_png_gray16(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height,
                      std::span<const std::uint16_t> values)
{
    write_bytes_atomically(path, png_gray16_file_bytes(width, height, values, path.string()));
}

RgbImage read_png_rgb(const std::filesystem::path& path)
{
    const std::string where = path.string();
    std::ifstream in;
    ReadStructs structs;
    PngContext context;
    Header header = open_png(path, in, structs, context);
    if (!rgb_transforms_step(structs.png, structs.info, &header)) {
        throw Error(where, std::string("not a valid PNG: ") + context.message);
    }
    if (header.row_bytes != std::size_t(header.width) * 3) {
        throw Error(where, "unsupported PNG layout (" + std::to_string(header.row_bytes) + " bytes a row after conversion)");
    }
    RgbImage image;
    image.width = header.width;
    image.height = header.height;
    image.pixels.resize(std::size_t(header.width) * header.height * 3);
    read_pixels(where, structs, context, image.pixels.data(), header.height, header.row_bytes);
    return image;
}

std::vector<std::uint16_t> read_png_gray16(const std::filesystem::path& path, std::uint32_t* width,
                                           std::uint32_t* height)
{
    const std::string where = path.string();
    std::ifstream in;
    ReadStructs structs;
    PngContext context;
    Header header = open_png(path, in, structs, context);
    if (header.color_type != PNG_COLOR_TYPE_GRAY && header.color_type != PNG_COLOR_TYPE_GRAY_ALPHA) {
        throw Error(where, "not a greyscale PNG (colour type " + std::to_string(header.color_type) + ")");
    }
    if (!gray_transforms_step(structs.png, structs.info, &header)) {
        throw Error(where, std::string("not a valid PNG: ") + context.message);
    }
    const std::size_t sample_bytes = header.bit_depth == 16 ? 2 : 1;
    if (header.row_bytes != std::size_t(header.width) * sample_bytes) {
        throw Error(where, "unsupported PNG layout (" + std::to_string(header.row_bytes) + " bytes a row after conversion)");
    }
    std::vector<std::uint16_t> values(std::size_t(header.width) * header.height);
    if (sample_bytes == 2) {
        read_pixels(where, structs, context, reinterpret_cast<std::uint8_t*>(values.data()), header.height,
                    header.row_bytes);
    } else {
        std::vector<std::uint8_t> bytes(values.size());
        read_pixels(where, structs, context, bytes.data(), header.height, header.row_bytes);
        for (std::size_t i = 0; i < bytes.size(); ++i) values[i] = bytes[i];
    }
    if (width != nullptr) *width = header.width;
    if (height != nullptr) *height = header.height;
    return values;
}

}  // namespace mfpc
