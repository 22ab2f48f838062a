#include <gtest/gtest.h>

#include "mfpc/core/error.hpp"
#include "mfpc/simulation/primitive_scene.hpp"

namespace mfpc {
namespace {

TEST(PrimitiveScene, SameSeedSameScene)
{
    const PrimitiveScene a = make_primitive_scene({.seed = 5});
    const PrimitiveScene b = make_primitive_scene({.seed = 5});
    const PrimitiveScene c = make_primitive_scene({.seed = 6});
    EXPECT_EQ(a.cloud.points, b.cloud.points);
    EXPECT_EQ(a.cloud.source_index, b.cloud.source_index);
    EXPECT_NE(a.cloud.points, c.cloud.points);
}

TEST(PrimitiveScene, OrganizedWithPixelPositions)
{
    const PrimitiveScene scene = make_primitive_scene({.width = 160, .height = 120, .focal_length = 131.25f});
    EXPECT_EQ(scene.cloud.width, 160u);
    EXPECT_EQ(scene.cloud.height, 120u);
    ASSERT_EQ(scene.cloud.source_index.size(), scene.cloud.size());
    EXPECT_LT(scene.cloud.size(), 160u * 120u);  // rays past the table return nothing
    for (std::size_t i = 1; i < scene.cloud.size(); ++i) {
        EXPECT_LT(scene.cloud.source_index[i - 1], scene.cloud.source_index[i]);
    }
    // The 640x480 field of view at a quarter of the resolution.
    // A pinhole camera: each point projects back onto its own pixel (noise moves points along the ray).
    for (std::size_t i = 0; i < scene.cloud.size(); i += 97) {
        const Point& p = scene.cloud.points[i];
        const float u = 131.25f * p.x() / p.z() + 79.5f;
        const float v = 131.25f * p.y() / p.z() + 59.5f;
        EXPECT_NEAR(u, float(scene.cloud.source_index[i] % 160), 1e-2f);
        EXPECT_NEAR(v, float(scene.cloud.source_index[i] / 160), 1e-2f);
    }
}

TEST(PrimitiveScene, EachObjectInsideItsFovea)
{
    const PrimitiveScene scene = make_primitive_scene({.seed = 3, .objects = 6, .depth_noise = 0.0f});
    ASSERT_EQ(scene.objects.size(), 6u);
    ASSERT_EQ(scene.fovea.structures.size(), 6u);
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const FoveatedStructure& s = scene.fovea.structures[i];
        const Box fovea = s.level_box(s.levels);
        EXPECT_TRUE(fovea.contains(Box{scene.objects[i].bounds.min.array() + 1e-4f,
                                       scene.objects[i].bounds.max.array() - 1e-4f}))
            << "object " << i;
        EXPECT_TRUE(s.outer_box().contains(fovea));
        // Some scene points fall on each object (it is in view).
        std::size_t on_object = 0;
        for (const Point& p : scene.cloud.points) on_object += scene.objects[i].bounds.contains(p);
        EXPECT_GT(on_object, 50u) << "object " << i;
    }
}

TEST(PrimitiveScene, RejectsBadParameters)
{
    EXPECT_THROW(make_primitive_scene({.objects = 0}), Error);
    EXPECT_THROW(make_primitive_scene({.objects = 9}), Error);
    EXPECT_THROW(make_primitive_scene({.width = 2}), Error);
    EXPECT_THROW(make_primitive_scene({.depth_noise = -1.0f}), Error);
}

}  // namespace
}  // namespace mfpc
