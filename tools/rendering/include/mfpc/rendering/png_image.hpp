#pragma once

/// @file
/// @brief PNG files through libpng: 8-bit RGB and 16-bit greyscale images.
///
/// Writers go through a temporary file beside `path` and rename it, so a failure leaves no
/// half-written image. Every failure (a bad size, a pixel buffer of the wrong length, a libpng
/// error, an unreadable or truncated file, a file that is not a PNG) throws mfpc::Error naming the
/// file.

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace mfpc {

/// @brief An 8-bit RGB image: pixels holds width * height * 3 bytes, row by row from the top, r g b
/// per pixel.
struct RgbImage {
    std::uint32_t width = 0;          ///< Width in pixels.
    std::uint32_t height = 0;         ///< Height in pixels.
    std::vector<std::uint8_t> pixels;  ///< width * height * 3 bytes, row by row from the top.
};

/// @brief The bytes of the 8-bit RGB PNG write_png writes, for a caller that writes several
/// outputs all or none.
/// @param image The image.
/// @param where The name errors give.
/// @return The whole file.
/// @throws mfpc::Error as write_png does for the image.
std::string png_file_bytes(const RgbImage& image, const std::string& where);

/// @brief The bytes of the 16-bit greyscale PNG write_png_gray16 writes.
/// @param width Width in pixels.
/// @param height Height in pixels.
/// @param values width * height values, row by row from the top.
/// @param where The name errors give.
/// @return The whole file.
/// @throws mfpc::Error as write_png_gray16 does for the image.
std::string png_gray16_file_bytes(std::uint32_t width, std::uint32_t height, std::span<const std::uint16_t> values,
                                  const std::string& where);

/// @brief Writes an 8-bit RGB PNG, atomically.
/// @param path The file.
/// @param image The image.
/// @throws mfpc::Error naming the file for an empty or too large size, a pixel buffer of the wrong
/// length, a libpng error, or a file that cannot be written or renamed into place.
void write_png(const std::filesystem::path& path, const RgbImage& image);

/// @brief Writes a 16-bit greyscale PNG (per-pixel labels, depth in millimetres), atomically.
/// @param path The file.
/// @param width Width in pixels.
/// @param height Height in pixels.
/// @param values width * height values, row by row from the top.
/// @throws mfpc::Error naming the file for an empty or too large size, a wrong number of values, a
/// libpng error, or a file that cannot be written or renamed into place.
void write_png_gray16(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height,
                      std::span<const std::uint16_t> values);

/// @brief Reads any PNG as 8-bit RGB: palettes are expanded, grey is copied to r, g and b, 16-bit
/// samples keep their high byte and alpha is dropped (not composited).
/// @param path The file.
/// @return The image.
/// @throws mfpc::Error naming the file for a missing, unreadable or truncated file, a file that is
/// not a valid PNG, or a size or layout it cannot hold.
RgbImage read_png_rgb(const std::filesystem::path& path);

/// @brief Reads a greyscale PNG (alpha dropped) as its sample values, unscaled: a 16-bit file gives
/// 0..65535, an 8-bit one 0..255. Colour PNGs are refused rather than converted, since a label
/// image that arrives as colour has lost its labels.
/// @param path The file.
/// @param width When given, receives the width in pixels.
/// @param height When given, receives the height in pixels.
/// @return width * height values, row by row from the top.
/// @throws mfpc::Error naming the file for a colour PNG, a missing, unreadable or truncated file, a
/// file that is not a valid PNG, or a size or layout it cannot hold.
std::vector<std::uint16_t> read_png_gray16(const std::filesystem::path& path, std::uint32_t* width,
                                           std::uint32_t* height);

}  // namespace mfpc
