// The renderer checked pixel by pixel on synthetic clouds whose projections are known exactly:
// covered regions, box edges on their rows, region colours, overlays, views, thread counts.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "mfpc/core/error.hpp"
#include "mfpc/simulation/primitive_scene.hpp"
#include "mfpc/rendering/renderer.hpp"

namespace mfpc {
namespace {

constexpr float f = 525.0f, cx = 319.5f, cy = 239.5f;

// An organized 640 x 480 cloud (the Kinect's intrinsics) holding a plane at depth z over the
// pixels u0 <= u < u1, v0 <= v < v1: each point lies exactly on its pixel's ray.
PointCloud plane(float z, int u0, int u1, int v0, int v1)
{
    PointCloud cloud;
    cloud.width = 640;
    cloud.height = 480;
    for (int v = v0; v < v1; ++v) {
        for (int u = u0; u < u1; ++u) {
            cloud.points.emplace_back((float(u) - cx) * z / f, (float(v) - cy) * z / f, z);
            cloud.source_index.push_back(std::uint32_t(v * 640 + u));
        }
    }
    return cloud;
}

Rgb pixel(const RgbImage& image, int u, int v)
{
    const std::uint8_t* p = image.pixels.data() + (std::size_t(v) * image.width + std::size_t(u)) * 3;
    return {p[0], p[1], p[2]};
}

bool near(Rgb a, Rgb b, int tolerance)
{
    return std::abs(int(a.r) - int(b.r)) <= tolerance && std::abs(int(a.g) - int(b.g)) <= tolerance &&
           std::abs(int(a.b) - int(b.b)) <= tolerance;
}

std::string text(Rgb c)
{
    return "(" + std::to_string(c.r) + ", " + std::to_string(c.g) + ", " + std::to_string(c.b) + ")";
}

const Rgb white{255, 255, 255};

// One structure around (0, 0, 1.1): outer box x, y -0.1..0.1, z 1.0..1.2; fovea 0.1 on a side.
FoveationConfig one_box(int levels = 1)
{
    FoveationConfig config;
    FoveatedStructure structure;
    structure.outer_min = {-0.1f, -0.1f, 1.0f};
    structure.outer_size = {0.2f, 0.2f, 0.2f};
    structure.fovea_size = {0.1f, 0.1f, 0.1f};
    structure.levels = levels;
    config.structures.push_back(structure);
    return config;
}

TEST(RenderView, ParsesTheThreeViews)
{
    EXPECT_EQ(parse_render_view("camera").kind, ViewKind::camera);
    EXPECT_EQ(parse_render_view("top").kind, ViewKind::top);
    const RenderView orbit = parse_render_view("orbit:-32.5");
    EXPECT_EQ(orbit.kind, ViewKind::orbit);
    EXPECT_FLOAT_EQ(orbit.orbit_deg, -32.5f);
    EXPECT_EQ(parse_render_view("orbit:90").orbit_deg, 90.0f);
    EXPECT_EQ(to_string(parse_render_view("orbit:30")), "orbit:30");
    EXPECT_EQ(to_string(parse_render_view("top")), "top");
    for (const char* bad : {"", "Camera", "side", "orbit", "orbit:", "orbit:x", "orbit:30deg", "orbit: 30", "orbit:nan",
                            "orbit:inf", "top:1"}) {
        try {
            parse_render_view(bad);
            ADD_FAILURE() << "accepted '" << bad << "'";
        } catch (const Error& error) {
            EXPECT_EQ(error.where(), "view") << bad;
        }
    }
}

TEST(Renderer, PlaneCoversExactlyItsPixelsInCameraView)
{
    const PointCloud cloud = plane(1.0f, 100, 300, 50, 250);
    const RenderCamera camera = render_camera(cloud, {});
    EXPECT_NEAR(camera.intrinsics.fx, f, 1e-2);
    EXPECT_NEAR(camera.intrinsics.cx, cx, 1e-2);
    RenderStats stats;
    const RgbImage image = render_cloud(cloud, nullptr, {}, {}, &stats);
    ASSERT_EQ(image.width, 640u);
    ASSERT_EQ(image.height, 480u);
    EXPECT_EQ(stats.points, cloud.size());
    EXPECT_NEAR(stats.point_radius, 0.8f / f, 1e-5);  // spacing one pixel at 1 m
    int wrong = 0;
    for (int v = 0; v < 480; ++v) {
        for (int u = 0; u < 640; ++u) {
            const bool inside = u >= 100 && u < 300 && v >= 50 && v < 250;
            const Rgb c = pixel(image, u, v);
            if (inside != (c != white)) ++wrong;
            // Grey, lit head-on: the plane faces the camera, so Lambert keeps most of the light.
            if (inside && !(c.r == c.g && c.g == c.b && c.r > 140 && c.r <= outside_color.r)) ++wrong;
        }
    }
    EXPECT_EQ(wrong, 0);
}

TEST(Renderer, NormalsGiveOrientedDiscsOverTheSamePixels)
{
    PointCloud cloud = plane(1.0f, 100, 300, 50, 250);
    cloud.normals.assign(cloud.size(), Point(0.0f, 0.0f, -1.0f));
    const RgbImage image = render_cloud(cloud, nullptr, {}, {});
    int wrong = 0;
    for (int v = 0; v < 480; ++v) {
        for (int u = 0; u < 640; ++u) {
            const bool inside = u >= 100 && u < 300 && v >= 50 && v < 250;
            if (inside != (pixel(image, u, v) != white)) ++wrong;
        }
    }
    EXPECT_EQ(wrong, 0);
    // The normals light the discs: tilted 60 degrees from the plane's, Lambert gives the discs
    // ambient + (1 - ambient) |n . ray| of the light (0.54 here, against 0.98 facing).
    const Rgb facing = pixel(image, 200, 150);
    cloud.normals.assign(cloud.size(), Point(-std::sin(1.0472f), 0.0f, -std::cos(1.0472f)));
    const RgbImage tilted = render_cloud(cloud, nullptr, {}, {});
    const Eigen::Vector3f ray = Eigen::Vector3f((200.0f - cx) / f, (150.0f - cy) / f, 1.0f).normalized();
    const float light = 0.35f + 0.65f * std::abs(ray.dot(Eigen::Vector3f(-std::sin(1.0472f), 0.0f, -std::cos(1.0472f))));
    EXPECT_NEAR(pixel(tilted, 200, 150).r, float(outside_color.r) * light, 1.0f) << text(pixel(tilted, 200, 150));
    EXPECT_GT(facing.r, pixel(tilted, 200, 150).r + 40);
}

TEST(Renderer, BoxEdgeLandsOnItsRowInTheStructuresColour)
{
    // A few points far off in a corner, so the cloud is not empty and hides nothing.
    PointCloud cloud;
    for (int i = 0; i < 10; ++i) {
        for (int j = 0; j < 10; ++j) cloud.points.emplace_back(-1.2f + 0.02f * float(i), -0.8f + 0.02f * float(j), 3.0f);
    }
    cloud.width = std::uint32_t(cloud.size());
    const FoveationConfig config = one_box();
    const RenderCamera camera = render_camera(cloud, {});
    // The near bottom edge: z = 1, y = 0.1, x -0.1..0.1 -> row cy + 525 * 0.1 = 292, columns 267..372.
    const Eigen::Vector3f projected = camera.project({0.0f, 0.1f, 1.0f});
    EXPECT_NEAR(projected.x(), cx, 1e-4);
    EXPECT_NEAR(projected.y(), 292.0f, 1e-4);
    RenderStats stats;
    const RgbImage image = render_cloud(cloud, &config, {}, {}, &stats);
    EXPECT_EQ(stats.boxes, 2u);
    const Rgb edge = structure_color(0);
    for (int u = 280; u <= 360; ++u) {
        EXPECT_EQ(pixel(image, u, 292), edge) << "u " << u << ": " << text(pixel(image, u, 292));
        // 1.5 pixels wide, centred on row 292: rows 291 and 293 are just outside.
        for (int v : {286, 287, 288, 289, 290, 291, 293, 294, 295, 296, 297, 298}) {
            EXPECT_EQ(pixel(image, u, v), white) << "u " << u << " v " << v;
        }
    }
    // The far bottom edge (z = 1.2): row 239.5 + 43.75 = 283.25.
    EXPECT_EQ(pixel(image, 320, 283), edge);
    // The vertical near edges: x = -0.1 -> column 267, x = 0.1 -> column 372, rows 187..292.
    for (int v = 200; v <= 280; v += 10) {
        EXPECT_EQ(pixel(image, 267, v), edge) << v;
        EXPECT_EQ(pixel(image, 372, v), edge) << v;
        EXPECT_EQ(pixel(image, 262, v), white) << v;
    }
}

TEST(Renderer, HiddenBoxEdgesAreFaint)
{
    // A plane at z = 1.1 in front of the box's far face (z = 1.2) and behind its near face (z = 1).
    const PointCloud cloud = plane(1.1f, 0, 640, 0, 480);
    const FoveationConfig config = one_box();
    const RgbImage image = render_cloud(cloud, &config, {}, {});
    const Rgb edge = structure_color(0);
    EXPECT_EQ(pixel(image, 320, 292), edge);  // near edge, in front of the plane
    // Far edge, behind the plane: a blend of the plane and the edge.
    const Rgb far = pixel(image, 320, 283);
    const Rgb plane_colour = pixel(image, 320, 286);
    EXPECT_NE(far, edge);
    EXPECT_NE(far, plane_colour);
    EXPECT_TRUE(near(far, {std::uint8_t(plane_colour.r + (int(edge.r) - plane_colour.r) * 0.3),
                           std::uint8_t(plane_colour.g + (int(edge.g) - plane_colour.g) * 0.3),
                           std::uint8_t(plane_colour.b + (int(edge.b) - plane_colour.b) * 0.3)},
                     3))
        << text(far) << " plane " << text(plane_colour) << " edge " << text(edge);
}

TEST(Renderer, PointsTakeTheColourOfTheirRegion)
{
    // A plane at z = 1.1 through the middle of the box: the fovea (x, y -0.05..0.05) and level 0
    // around it, the rest outside. Lit head-on near the centre, so colours are nearly exact.
    const PointCloud cloud = plane(1.1f, 0, 640, 0, 480);
    const FoveationConfig config = one_box();
    const RgbImage image = render_cloud(cloud, &config, {}, {});
    // x = 0.02 -> u = 319.5 + 525 * 0.02 / 1.1 = 329; x = 0.075 -> 355; x = 0.15 -> 391.
    EXPECT_TRUE(near(pixel(image, 329, 245), region_color(0, 1, 1), 2)) << text(pixel(image, 329, 245));
    EXPECT_TRUE(near(pixel(image, 355, 245), region_color(0, 0, 1), 2)) << text(pixel(image, 355, 245));
    EXPECT_TRUE(near(pixel(image, 391, 245), outside_color, 2)) << text(pixel(image, 391, 245));
}

TEST(Renderer, RedundancyTreatmentPicksTheDensestLevel)
{
    // Two overlapping structures on a plane at z = 1.1: structure 0 as in one_box (level 0 x
    // -0.1..0.1, fovea -0.05..0.05), structure 1 moved by 0.12 in x (level 0 x 0.02..0.22, fovea
    // 0.07..0.17). Columns chosen clear of every box edge.
    const PointCloud cloud = plane(1.1f, 0, 640, 0, 480);
    FoveationConfig config = one_box();
    FoveatedStructure second = config.structures[0];
    second.outer_min.x() += 0.12f;
    config.structures.push_back(second);
    const RgbImage image = render_cloud(cloud, &config, {}, {});
    auto column = [](float x) { return int(std::lround(cx + f * x / 1.1f)); };
    // x = 0.03: structure 0's fovea (d = 0.005) beats structure 1's level 0 (d = 0.02).
    EXPECT_TRUE(near(pixel(image, column(0.03f), 245), region_color(0, 1, 1), 2));
    // x = 0.06: level 0 of both, same density and level: the lower structure index.
    EXPECT_TRUE(near(pixel(image, column(0.06f), 245), region_color(0, 0, 1), 2));
    // x = 0.085: structure 0's level 0 loses to structure 1's fovea.
    EXPECT_TRUE(near(pixel(image, column(0.085f), 245), region_color(1, 1, 1), 2));
    // x = 0.12: structure 1's fovea alone.
    EXPECT_TRUE(near(pixel(image, column(0.12f), 245), region_color(1, 1, 1), 2));
    EXPECT_NE(region_color(0, 1, 1), region_color(1, 1, 1));
}

TEST(Renderer, CloudColoursWithoutAFovea)
{
    PointCloud cloud = plane(1.0f, 200, 440, 120, 360);
    cloud.colors.assign(cloud.size(), Rgb{20, 200, 90});
    const RgbImage image = render_cloud(cloud, nullptr, {}, {});
    EXPECT_TRUE(near(pixel(image, 320, 240), Rgb{20, 200, 90}, 2)) << text(pixel(image, 320, 240));
}

TEST(Renderer, OverlaysShowRedWherePlaced)
{
    const PointCloud cloud = plane(1.0f, 0, 640, 0, 480);
    // A patch lying on the plane (the same points: an instance sitting on the scene), one in front
    // of it and one behind it.
    const PointCloud on = plane(1.0f, 300, 340, 220, 260);
    const PointCloud front = plane(0.8f, 100, 140, 100, 140);
    const PointCloud behind = plane(1.5f, 500, 540, 300, 340);
    std::vector<RenderOverlay> overlays(3);
    overlays[0].points = on.points;
    overlays[1].points = front.points;
    overlays[2].points = behind.points;
    overlays[2].color = {0, 0, 255};
    RenderStats stats;
    const RgbImage image = render_cloud(cloud, nullptr, overlays, {}, &stats);
    EXPECT_EQ(stats.overlay_points, on.size() + front.size() + behind.size());
    const Rgb red{220, 30, 30};
    for (int v = 220; v < 260; v += 3) {
        for (int u = 300; u < 340; u += 3) EXPECT_EQ(pixel(image, u, v), red) << u << " " << v;
    }
    for (int v = 100; v < 140; v += 3) {
        for (int u = 100; u < 140; u += 3) EXPECT_EQ(pixel(image, u, v), red) << u << " " << v;
    }
    EXPECT_NE(pixel(image, 298, 240), red);
    EXPECT_NE(pixel(image, 341, 240), red);
    EXPECT_NE(pixel(image, 320, 217), red);
    EXPECT_NE(pixel(image, 520, 320), (Rgb{0, 0, 255}));  // hidden by the plane
}

TEST(Renderer, OrbitZeroIsTheCameraView)
{
    const PrimitiveScene scene = make_primitive_scene();
    RenderParams camera_params;
    RenderParams orbit_params;
    orbit_params.view = parse_render_view("orbit:0");
    const RgbImage camera = render_cloud(scene.cloud, &scene.fovea, {}, camera_params);
    const RgbImage orbit = render_cloud(scene.cloud, &scene.fovea, {}, orbit_params);
    EXPECT_EQ(camera.pixels, orbit.pixels);
    orbit_params.view = parse_render_view("orbit:30");
    EXPECT_NE(render_cloud(scene.cloud, &scene.fovea, {}, orbit_params).pixels, camera.pixels);
}

TEST(Renderer, OrbitTurnsAboutTheCloudsCentre)
{
    const PrimitiveScene scene = make_primitive_scene();
    const Eigen::Vector3f center = bounding_box(scene.cloud.points).center();
    const Eigen::Vector3f seen = render_camera(scene.cloud, {}).project(center);
    for (float degrees : {-90.0f, 30.0f, 45.0f, 180.0f}) {
        RenderParams params;
        params.view = {ViewKind::orbit, degrees};
        const RenderCamera camera = render_camera(scene.cloud, params);
        // The camera moved rigidly about an axis through the centre: the centre stays where the
        // sensor saw it, at the same depth.
        EXPECT_TRUE(camera.project(center).isApprox(seen, 1e-4f)) << degrees;
        EXPECT_NEAR((camera.position - center).norm(), center.norm(), 1e-4) << degrees;
        EXPECT_NEAR(camera.position.y(), 0.0f, 1e-5) << degrees;
        EXPECT_TRUE(camera.down.isApprox(Eigen::Vector3f::UnitY()));
        EXPECT_TRUE(camera.right.cross(camera.down).isApprox(camera.forward, 1e-5f));
    }
    // A positive angle walks the camera to its right (+x).
    RenderParams params;
    params.view = parse_render_view("orbit:30");
    EXPECT_GT(render_camera(scene.cloud, params).position.x(), 0.0f);
}

TEST(Renderer, TopViewHoldsTheWholeCloud)
{
    const PrimitiveScene scene = make_primitive_scene();
    RenderParams params;
    params.view.kind = ViewKind::top;
    const RenderCamera camera = render_camera(scene.cloud, params);
    EXPECT_TRUE(camera.forward.isApprox(Eigen::Vector3f::UnitY()));
    const Box bounds = bounding_box(scene.cloud.points);
    for (int i = 0; i < 8; ++i) {
        const Point corner((i & 1) ? bounds.max.x() : bounds.min.x(), (i & 2) ? bounds.max.y() : bounds.min.y(),
                           (i & 4) ? bounds.max.z() : bounds.min.z());
        const Eigen::Vector3f p = camera.project(corner);
        EXPECT_GT(p.z(), 0.0f);
        EXPECT_GE(p.x(), 0.0f);
        EXPECT_LE(p.x(), float(camera.intrinsics.width - 1));
        EXPECT_GE(p.y(), 0.0f);
        EXPECT_LE(p.y(), float(camera.intrinsics.height - 1));
    }
    // Far (+z) is up in the picture.
    EXPECT_LT(camera.project(bounds.max).y(), camera.project(bounds.min).y());
    const RgbImage image = render_cloud(scene.cloud, &scene.fovea, {}, params);
    std::size_t drawn = 0;
    for (std::size_t i = 0; i < image.pixels.size(); i += 3) drawn += image.pixels[i] != 255 || image.pixels[i + 1] != 255;
    EXPECT_GT(drawn, image.pixels.size() / 3 / 10);
}

TEST(Renderer, SizeChangesResolutionNotFieldOfView)
{
    const PointCloud cloud = plane(1.0f, 100, 300, 50, 250);
    RenderParams params;
    params.width = 320;
    params.height = 240;
    const RenderCamera camera = render_camera(cloud, params);
    EXPECT_NEAR(camera.intrinsics.fx, 262.5f, 1e-2);
    EXPECT_NEAR(camera.intrinsics.cx, 159.5f, 1e-2);
    const RgbImage image = render_cloud(cloud, nullptr, {}, params);
    ASSERT_EQ(image.width, 320u);
    ASSERT_EQ(image.height, 240u);
    // The plane covered columns 100..299 and rows 50..249 at full size: 50..149 and 25..124 now.
    EXPECT_NE(pixel(image, 52, 27), white);
    EXPECT_NE(pixel(image, 147, 122), white);
    EXPECT_EQ(pixel(image, 48, 80), white);
    EXPECT_EQ(pixel(image, 152, 80), white);
    EXPECT_EQ(pixel(image, 100, 23), white);
    EXPECT_EQ(pixel(image, 100, 127), white);

    // An unorganized cloud keeps the Kinect's field of view at any size.
    PointCloud loose = cloud;
    loose.width = std::uint32_t(loose.size());
    loose.height = 1;
    loose.source_index.clear();
    const RenderCamera unorganized = render_camera(loose, params);
    EXPECT_FLOAT_EQ(unorganized.intrinsics.fx, 262.5f);
    EXPECT_FLOAT_EQ(unorganized.intrinsics.cy, 119.5f);
    EXPECT_EQ(render_camera(loose, {}).intrinsics.width, 640u);
}

TEST(Renderer, SameImageWithOneThreadOrMany)
{
    const PrimitiveScene scene = make_primitive_scene();
    std::vector<RenderOverlay> overlays(1);
    for (std::size_t i = 0; i < scene.cloud.size(); i += 7) {
        if (scene.objects[0].bounds.contains(scene.cloud.points[i])) overlays[0].points.push_back(scene.cloud.points[i]);
    }
    ASSERT_FALSE(overlays[0].points.empty());
    for (const char* view : {"camera", "top", "orbit:-40"}) {
        RenderParams params;
        params.view = parse_render_view(view);
        const RgbImage many = render_cloud(scene.cloud, &scene.fovea, overlays, params);
        RgbImage one;
        {
            const tbb::global_control single(tbb::global_control::max_allowed_parallelism, 1);
            one = render_cloud(scene.cloud, &scene.fovea, overlays, params);
        }
        EXPECT_EQ(one.pixels, many.pixels) << view;
    }
}

TEST(Renderer, BadInputIsAnError)
{
    const PointCloud cloud = plane(1.0f, 100, 300, 50, 250);
    EXPECT_THROW(render_cloud(PointCloud{}, nullptr, {}, {}), Error);
    RenderParams params;
    params.width = 320;  // height missing
    EXPECT_THROW(render_cloud(cloud, nullptr, {}, params), Error);
    params.height = 20000;
    EXPECT_THROW(render_cloud(cloud, nullptr, {}, params), Error);
    params = {};
    params.point_radius = -1.0f;
    EXPECT_THROW(render_cloud(cloud, nullptr, {}, params), Error);
    params.point_radius = std::nanf("");
    EXPECT_THROW(render_cloud(cloud, nullptr, {}, params), Error);
    std::vector<RenderOverlay> overlays(1);
    overlays[0].points.emplace_back(0.0f, std::nanf(""), 1.0f);
    EXPECT_THROW(render_cloud(cloud, nullptr, overlays, {}), Error);
}

TEST(Renderer, GivenRadiusIsUsed)
{
    // Points 10 pixels apart with a 2-pixel radius: dots, not a surface.
    PointCloud cloud;
    for (int v = 0; v < 480; v += 10) {
        for (int u = 0; u < 640; u += 10) cloud.points.emplace_back((float(u) - cx) / f, (float(v) - cy) / f, 1.0f);
    }
    cloud.width = std::uint32_t(cloud.size());
    RenderParams params;
    params.point_radius = 2.0f / f;
    RenderStats stats;
    const RgbImage image = render_cloud(cloud, nullptr, {}, params, &stats);
    EXPECT_FLOAT_EQ(stats.point_radius, 2.0f / f);
    EXPECT_NE(pixel(image, 320, 240), white);
    EXPECT_NE(pixel(image, 321, 241), white);
    EXPECT_EQ(pixel(image, 325, 245), white);
    // Without a radius, the spacing (10 pixels) closes the gaps.
    const RgbImage filled = render_cloud(cloud, nullptr, {}, {});
    EXPECT_NE(pixel(filled, 325, 245), white);
}

}  // namespace
}  // namespace mfpc
