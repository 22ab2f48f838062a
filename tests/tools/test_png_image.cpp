// PNG reading and writing: exact round trips, and one clear mfpc::Error for every bad file.
#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cli_runner.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/rendering/png_image.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

RgbImage random_image(std::uint32_t width, std::uint32_t height, std::uint32_t seed)
{
    std::mt19937 random(seed);
    RgbImage image;
    image.width = width;
    image.height = height;
    image.pixels.resize(std::size_t(width) * height * 3);
    for (auto& byte : image.pixels) byte = std::uint8_t(random() & 0xFFu);
    return image;
}

// The error a call throws, or a failure when it throws none (or another type).
template <class Call>
Error error_of(Call&& call)
{
    try {
        call();
    } catch (const Error& error) {
        return error;
    }
    ADD_FAILURE() << "no mfpc::Error thrown";
    return Error("none", "none");
}

TEST(PngImage, RgbRoundTripIsExact)
{
    const test::TempDir dir;
    // An odd width, so rows are not a multiple of 4 bytes.
    const RgbImage image = random_image(37, 23, 7);
    write_png(dir / "a.png", image);
    const RgbImage back = read_png_rgb(dir / "a.png");
    EXPECT_EQ(back.width, image.width);
    EXPECT_EQ(back.height, image.height);
    EXPECT_EQ(back.pixels, image.pixels);
}

TEST(PngImage, Gray16RoundTripIsExact)
{
    const test::TempDir dir;
    std::vector<std::uint16_t> values(31 * 17);
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = std::uint16_t(i * 2654435761u >> 7);
    // Values whose two bytes differ catch a byte-order slip; the extremes catch a sign slip.
    values[0] = 0;
    values[1] = 0xFFFF;
    values[2] = 0x0102;
    values[3] = 0x8000;
    write_png_gray16(dir / "labels.png", 31, 17, values);
    std::uint32_t width = 0, height = 0;
    const std::vector<std::uint16_t> back = read_png_gray16(dir / "labels.png", &width, &height);
    EXPECT_EQ(width, 31u);
    EXPECT_EQ(height, 17u);
    EXPECT_EQ(back, values);
}

TEST(PngImage, Gray16ReadAsRgbKeepsTheHighByte)
{
    const test::TempDir dir;
    const std::vector<std::uint16_t> values = {0x0000, 0x12FF, 0xAB01, 0xFFFF};
    write_png_gray16(dir / "g.png", 2, 2, values);
    const RgbImage image = read_png_rgb(dir / "g.png");
    ASSERT_EQ(image.pixels.size(), 12u);
    for (std::size_t i = 0; i < values.size(); ++i) {
        for (int c = 0; c < 3; ++c) EXPECT_EQ(image.pixels[3 * i + std::size_t(c)], values[i] >> 8) << i;
    }
}

TEST(PngImage, ColourIsNotReadAsLabels)
{
    const test::TempDir dir;
    write_png(dir / "rgb.png", random_image(4, 4, 1));
    const Error error = error_of([&] { read_png_gray16(dir / "rgb.png", nullptr, nullptr); });
    EXPECT_EQ(error.where(), (dir / "rgb.png").string());
    EXPECT_NE(error.reason().find("greyscale"), std::string::npos) << error.what();
}

TEST(PngImage, BadFilesAreErrorsNamingTheFile)
{
    const test::TempDir dir;
    write_png(dir / "good.png", random_image(64, 48, 3));
    const std::string good = test::slurp(dir / "good.png");
    ASSERT_GT(good.size(), 100u);
    struct Case {
        std::string name;
        std::string bytes;
        std::string reason;  // a piece of the expected reason
    };
    const std::vector<Case> cases = {
        {"empty.png", "", "not a PNG"},
        {"text.png", "this is plainly not an image, just some text", "not a PNG"},
        {"signature_only.png", good.substr(0, 8), "truncated"},
        {"half.png", good.substr(0, good.size() / 2), "truncated"},
        {"no_end.png", good.substr(0, good.size() - 12), "truncated"},
        // After the signature and IHDR (33 bytes), an sPLT chunk that claims 1.6 GB: libpng
        // allocated that before reading it (fuzz_png found it).
        {"huge_chunk.png", good.substr(0, 33) + std::string("\x60\x60\xff\xae" "sPLT" "E", 9), "claims 1616969646 bytes"},
    };
    for (const Case& c : cases) {
        const auto path = dir.write(c.name, c.bytes);
        const Error rgb = error_of([&] { read_png_rgb(path); });
        EXPECT_EQ(rgb.where(), path.string()) << c.name;
        EXPECT_NE(rgb.reason().find(c.reason), std::string::npos) << c.name << ": " << rgb.what();
        const Error gray = error_of([&] { read_png_gray16(path, nullptr, nullptr); });
        EXPECT_EQ(gray.where(), path.string()) << c.name;
    }
    // A damaged byte in the image data: zlib or the chunk CRC notices.
    std::string damaged = good;
    damaged[damaged.size() / 2] = char(damaged[damaged.size() / 2] ^ 0x55);
    const auto path = dir.write("damaged.png", damaged);
    EXPECT_EQ(error_of([&] { read_png_rgb(path); }).where(), path.string());

    const Error missing = error_of([&] { read_png_rgb(dir / "missing.png"); });
    EXPECT_EQ(missing.where(), (dir / "missing.png").string());
    EXPECT_NE(missing.reason().find("no such file"), std::string::npos) << missing.what();
    EXPECT_THROW(read_png_rgb(dir.path()), Error);
}

TEST(PngImage, BadImagesAreNotWrittenAndLeaveTheOldFile)
{
    const test::TempDir dir;
    const auto path = dir / "keep.png";
    const RgbImage old_image = random_image(5, 5, 9);
    write_png(path, old_image);

    RgbImage short_pixels = random_image(5, 5, 1);
    short_pixels.pixels.pop_back();
    EXPECT_THROW(write_png(path, short_pixels), Error);
    EXPECT_THROW(write_png(path, RgbImage{}), Error);
    const std::vector<std::uint16_t> values(6);
    EXPECT_THROW(write_png_gray16(path, 2, 2, values), Error);
    EXPECT_THROW(write_png_gray16(path, 0, 6, values), Error);
    EXPECT_THROW(write_png(dir / "no_such_dir" / "a.png", old_image), Error);

    EXPECT_EQ(read_png_rgb(path).pixels, old_image.pixels);
    // Nothing but the file itself: no temporary left behind.
    std::size_t files = 0;
    for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir.path())) ++files;
    EXPECT_EQ(files, 1u);
}

}  // namespace
}  // namespace mfpc
