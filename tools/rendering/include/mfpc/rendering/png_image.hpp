#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <vector>

namespace mfpc {

// An 8-bit RGB image: pixels holds width * height * 3 bytes, row by row from the top, r g b per pixel.
struct RgbImage {
    std::uint32_t width = 0;
    std::uint32_t height = 0;
    std::vector<std::uint8_t> pixels;
};

// PNG files through libpng. Writers go through a temporary file beside `path` and rename it, so a
// failure leaves no half-written image. Every failure (a bad size, a pixel buffer of the wrong
// length, a libpng error, an unreadable or truncated file, a file that is not a PNG) throws
// mfpc::Error naming the file.

void write_png(const std::filesystem::path& path, const RgbImage& image);

// A 16-bit greyscale PNG (per-pixel labels, depth in millimetres): values row by row from the top.
void write_png_gray16(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height,
                      std::span<const std::uint16_t> values);

// Any PNG as 8-bit RGB: palettes are expanded, grey is copied to r, g and b, 16-bit samples keep
// their high byte and alpha is dropped (not composited).
RgbImage read_png_rgb(const std::filesystem::path& path);

// A greyscale PNG (alpha dropped) as its sample values, unscaled: a 16-bit file gives 0..65535,
// an 8-bit one 0..255. Colour PNGs are refused rather than converted, since a label image that
// arrives as colour has lost its labels.
std::vector<std::uint16_t> read_png_gray16(const std::filesystem::path& path, std::uint32_t* width,
                                           std::uint32_t* height);

}  // namespace mfpc
