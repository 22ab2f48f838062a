#pragma once

#include <cmath>
#include <vector>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc::test {

// A mug-like hollow model with outward normals, sampled every 4 mm: a cylinder shell about the y
// axis (outer radius 4 cm, inner 3.6 cm, 10 cm tall, open at y = -5 cm), a floor at y = +5 cm, and
// a 3 x 4 x 2 cm block on the +x side for a handle (x 4 to 7 cm). Its inside is what a convex model never has:
// surface turned to the sensor behind the model's own front wall.
struct HollowCup {
    std::vector<Point> points, normals;
};
inline HollowCup hollow_cup()
{
    constexpr float step = 0.004f, pi = 3.14159265f;
    HollowCup cup;
    auto add = [&](const Point& p, const Point& n) {
        cup.points.push_back(p);
        cup.normals.push_back(n);
    };
    for (const float radius : {0.040f, 0.036f}) {
        const int around = int(std::round(2.0f * pi * radius / step));
        const float outward = radius > 0.038f ? 1.0f : -1.0f;
        for (int k = 0; k < around; ++k) {
            const float angle = 2.0f * pi * float(k) / float(around);
            const Point radial(std::cos(angle), 0.0f, std::sin(angle));
            for (float y = -0.05f; y <= 0.05f + 1e-6f; y += step)
                add(Point(radius * radial.x(), y, radius * radial.z()), outward * radial);
        }
    }
    for (float x = -0.036f; x <= 0.036f + 1e-6f; x += step)
        for (float z = -0.036f; z <= 0.036f + 1e-6f; z += step)
            if (x * x + z * z <= 0.036f * 0.036f) add(Point(x, 0.05f, z), Point(0.0f, -1.0f, 0.0f));
    // The handle block's faces but the one against the wall.
    for (float y = -0.02f; y <= 0.02f + 1e-6f; y += step) {
        for (float z = -0.01f; z <= 0.01f + 1e-6f; z += step) add(Point(0.07f, y, z), Point(1.0f, 0.0f, 0.0f));
        for (float x = 0.04f; x <= 0.07f + 1e-6f; x += step) {
            add(Point(x, y, -0.01f), Point(0.0f, 0.0f, -1.0f));
            add(Point(x, y, 0.01f), Point(0.0f, 0.0f, 1.0f));
        }
    }
    return cup;
}

}  // namespace mfpc::test
