// The PNG readers (read_png_rgb; read_png_gray16, which reads label and depth images) on a fuzzed
// file. Asserts the image they return has width x height pixels of the documented size.
#include <cstdint>

#include "fuzz_support.hpp"
#include "mfpc/rendering/png_image.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    const auto path = fuzz::write_input("in.png", data, size);
    fuzz::run([&] {
        const RgbImage image = read_png_rgb(path);
        fuzz::check(image.pixels.size() == std::size_t(image.width) * image.height * 3, "rgb pixels are not w x h x 3");
        fuzz::check(image.width > 0 && image.height > 0, "an empty rgb image was returned");
    });
    fuzz::run([&] {
        std::uint32_t width = 0, height = 0;
        const auto values = read_png_gray16(path, &width, &height);
        fuzz::check(values.size() == std::size_t(width) * height, "gray values are not w x h");
        fuzz::check(width > 0 && height > 0, "an empty gray image was returned");
    });
    return 0;
}
