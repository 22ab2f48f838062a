// render_cloud (`mfpc render`, Embree) on a small fuzzed cloud: up to 200 points, on a grid in
// front of the sensor or any finite float bits; a fuzzed view (camera, top, orbit:DEG), image
// size, disc radius, optional normals, colours, a fovea config and an overlay. Asserts the picture
// has the asked size and the stats count what was drawn.
#include <vector>

#include "fuzz_support.hpp"
#include "mfpc/index/distinct_points.hpp"
#include "mfpc/rendering/renderer.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    fuzz::Bytes bytes(data, size);
    const int flags = bytes.byte();
    RenderParams params;
    params.width = std::uint32_t(bytes.in(1, 64));
    params.height = std::uint32_t(bytes.in(1, 48));
    const int view = bytes.in(0, 2);
    params.view.kind = view == 0 ? ViewKind::camera : view == 1 ? ViewKind::top : ViewKind::orbit;
    params.view.orbit_deg = bytes.grid(-360, 360, 48);
    params.point_radius = flags & 1 ? bytes.grid(0, 0.05f, 10) : 0.0f;
    const bool raw = flags & 2;
    PointCloud cloud;
    std::vector<RenderOverlay> overlays;
    if (flags & 4) overlays.push_back({{Point(0, 0, 1), Point(0.01f, 0, 1), Point(0, 0.01f, 1)}});
    FoveationConfig fovea;
    if (flags & 8) {
        FoveatedStructure structure;
        structure.outer_min = Point(-0.5f, -0.5f, 0.5f);
        structure.fovea_size = Point(0.2f, 0.2f, 0.2f);
        fovea.structures.push_back(structure);
    }
    while (bytes.left() >= (raw ? 12u : 6u) && cloud.size() < 200) {
        const Point p = raw ? Point(bytes.raw_float(), bytes.raw_float(), bytes.raw_float())
                            : Point(bytes.grid(-0.5f, 0.5f, 64), bytes.grid(-0.5f, 0.5f, 64), bytes.grid(0.3f, 2, 64));
        if (!fuzz::finite(p)) continue;
        cloud.points.push_back(p);
    }
    if (cloud.empty()) return 0;
    cloud.width = std::uint32_t(cloud.size());
    if (flags & 16) {
        for (std::size_t i = 0; i < cloud.size(); ++i) cloud.normals.emplace_back(0, 0, -1);
    }
    if (flags & 32) {
        for (std::size_t i = 0; i < cloud.size(); ++i) cloud.colors.push_back({std::uint8_t(i), 128, std::uint8_t(255 - i)});
    }
    fuzz::run([&] {
        RenderStats stats;
        const RgbImage image = render_cloud(cloud, fovea.structures.empty() ? nullptr : &fovea, overlays, params, &stats);
        fuzz::check(image.width == params.width && image.height == params.height, "the picture is not of the asked size");
        fuzz::check(image.pixels.size() == std::size_t(image.width) * image.height * 3, "pixels are not w x h x 3");
        // Copies of a point are drawn once.
        fuzz::check(stats.points == distinct_points(cloud.points).count, "stats.points is not the cloud's distinct positions");
        fuzz::check(stats.overlay_points == (overlays.empty() ? 0u : overlays[0].points.size()), "overlay points miscounted");
        fuzz::check(std::isfinite(stats.point_radius) && stats.point_radius >= 0, "the disc radius is not a finite size");
    });
    return 0;
}
