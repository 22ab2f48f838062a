#include "mfpc/simulation/primitive_scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>

#include <Eigen/Geometry>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

using Vec = Eigen::Vector3d;

// The scene is built in a table frame (z up, table top at z = 0) and seen from a camera above
// and in front of the table.
struct Primitive {
    enum class Kind { box, cylinder, sphere } kind;
    Vec center;     // box: centre; cylinder: base centre; sphere: centre
    Vec half_size;  // box: half extents; cylinder: (radius, radius, height); sphere: (radius, ...)
};

constexpr double table_half_x = 0.6;
constexpr double table_half_y = 0.4;
constexpr double miss = std::numeric_limits<double>::infinity();

double hit_box(const Vec& origin, const Vec& dir, const Vec& lo, const Vec& hi)
{
    double t_near = -miss;
    double t_far = miss;
    for (int a = 0; a < 3; ++a) {
        if (dir[a] == 0.0) {
            if (origin[a] < lo[a] || origin[a] > hi[a]) return miss;
            continue;
        }
        double t0 = (lo[a] - origin[a]) / dir[a];
        double t1 = (hi[a] - origin[a]) / dir[a];
        if (t0 > t1) std::swap(t0, t1);
        t_near = std::max(t_near, t0);
        t_far = std::min(t_far, t1);
    }
    return (t_near <= t_far && t_near > 0.0) ? t_near : miss;
}

double hit_sphere(const Vec& origin, const Vec& dir, const Vec& center, double radius)
{
    const Vec oc = origin - center;
    const double b = oc.dot(dir);
    const double c = oc.squaredNorm() - radius * radius;
    const double disc = b * b - c;
    if (disc < 0.0) return miss;
    const double t = -b - std::sqrt(disc);
    return t > 0.0 ? t : miss;
}

double hit_cylinder(const Vec& origin, const Vec& dir, const Vec& base, double radius, double height)
{
    double best = miss;
    // Side: (x - cx)² + (y - cy)² = r², 0 <= z - base.z <= height.
    const double ox = origin.x() - base.x();
    const double oy = origin.y() - base.y();
    const double a = dir.x() * dir.x() + dir.y() * dir.y();
    if (a > 0.0) {
        const double b = ox * dir.x() + oy * dir.y();
        const double c = ox * ox + oy * oy - radius * radius;
        const double disc = b * b - a * c;
        if (disc >= 0.0) {
            const double t = (-b - std::sqrt(disc)) / a;
            const double z = origin.z() + t * dir.z() - base.z();
            if (t > 0.0 && z >= 0.0 && z <= height) best = t;
        }
    }
    // Top cap.
    if (dir.z() != 0.0) {
        const double t = (base.z() + height - origin.z()) / dir.z();
        const Vec p = origin + t * dir;
        const double dx = p.x() - base.x();
        const double dy = p.y() - base.y();
        if (t > 0.0 && dx * dx + dy * dy <= radius * radius) best = std::min(best, t);
    }
    return best;
}

double hit(const Primitive& primitive, const Vec& origin, const Vec& dir)
{
    switch (primitive.kind) {
    case Primitive::Kind::box:
        return hit_box(origin, dir, primitive.center - primitive.half_size, primitive.center + primitive.half_size);
    case Primitive::Kind::cylinder:
        return hit_cylinder(origin, dir, primitive.center, primitive.half_size.x(), primitive.half_size.z());
    case Primitive::Kind::sphere:
        return hit_sphere(origin, dir, primitive.center, primitive.half_size.x());
    }
    return miss;
}

Box bounds_of(const Primitive& primitive)
{
    Vec lo = primitive.center - primitive.half_size;
    Vec hi = primitive.center + primitive.half_size;
    if (primitive.kind == Primitive::Kind::cylinder) {
        lo.z() = primitive.center.z();
        hi.z() = primitive.center.z() + primitive.half_size.z();
    }
    return {lo.cast<float>(), hi.cast<float>()};
}

}  // namespace

PrimitiveScene make_primitive_scene(const PrimitiveSceneParams& params)
{
    if (params.objects < 1 || params.objects > 8) {
        throw Error("procedural scene", "objects must be 1..8, got " + std::to_string(params.objects));
    }
    if (params.width < 8 || params.height < 8 || params.width > 8192 || params.height > 8192) {
        throw Error("procedural scene", "resolution must be 8..8192 pixels a side");
    }
    if (!(params.focal_length > 0.0f) || !(params.depth_noise >= 0.0f) || params.levels < 1) {
        throw Error("procedural scene", "focal length must be > 0, depth noise >= 0 and levels >= 1");
    }

    std::mt19937 rng(params.seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };

    // Objects on a grid of cells across the table, so they never interpenetrate.
    std::vector<Primitive> primitives;
    const int columns = 4;
    const double cell_x = 2.0 * table_half_x / columns;
    const double cell_y = table_half_y;
    std::vector<int> cells(8);
    for (int i = 0; i < 8; ++i) cells[std::size_t(i)] = i;
    std::shuffle(cells.begin(), cells.end(), rng);
    for (std::uint32_t i = 0; i < params.objects; ++i) {
        const int cell = cells[i];
        const double cx = -table_half_x + (cell % columns + 0.5) * cell_x + uniform(-0.02, 0.02);
        const double cy = -table_half_y + (cell / columns + 0.5) * cell_y + uniform(-0.02, 0.02);
        Primitive p{};
        switch (i % 3) {
        case 0: {
            p.kind = Primitive::Kind::box;
            p.half_size = Vec(uniform(0.03, 0.06), uniform(0.03, 0.06), uniform(0.05, 0.12));
            p.center = Vec(cx, cy, p.half_size.z());
            break;
        }
        case 1: {
            p.kind = Primitive::Kind::cylinder;
            const double r = uniform(0.03, 0.05);
            p.half_size = Vec(r, r, uniform(0.10, 0.22));
            p.center = Vec(cx, cy, 0.0);
            break;
        }
        default: {
            p.kind = Primitive::Kind::sphere;
            const double r = uniform(0.04, 0.07);
            p.half_size = Vec(r, r, r);
            p.center = Vec(cx, cy, r);
            break;
        }
        }
        primitives.push_back(p);
    }

    // Camera 0.9 m above the table and 1 m in front of its centre, looking at the centre.
    const Vec eye(0.0, -1.0, 0.9);
    const Vec target(0.0, 0.0, 0.0);
    const Vec forward = (target - eye).normalized();
    const Vec right = forward.cross(Vec(0, 0, 1)).normalized();
    const Vec down = forward.cross(right);
    Eigen::Matrix3d camera_to_table;
    camera_to_table.col(0) = right;
    camera_to_table.col(1) = down;
    camera_to_table.col(2) = forward;
    const Eigen::Matrix3d table_to_camera = camera_to_table.transpose();

    const double cx = (params.width - 1) * 0.5;
    const double cy = (params.height - 1) * 0.5;
    std::normal_distribution<double> noise(0.0, 1.0);

    PrimitiveScene scene;
    PointCloud& cloud = scene.cloud;
    cloud.width = params.width;
    cloud.height = params.height;
    for (std::uint32_t v = 0; v < params.height; ++v) {
        for (std::uint32_t u = 0; u < params.width; ++u) {
            const Vec ray_camera((u - cx) / params.focal_length, (v - cy) / params.focal_length, 1.0);
            const Vec dir = (camera_to_table * ray_camera).normalized();
            double t = miss;
            if (dir.z() < 0.0) {
                const double t_table = -eye.z() / dir.z();
                const Vec p = eye + t_table * dir;
                if (std::abs(p.x()) <= table_half_x && std::abs(p.y()) <= table_half_y) t = t_table;
            }
            for (const Primitive& primitive : primitives) t = std::min(t, hit(primitive, eye, dir));
            // The noise is drawn for every pixel, hit or not, so a scene does not depend on
            // which pixels hit.
            const double n = noise(rng);
            if (t == miss) continue;
            Vec point_camera = table_to_camera * (t * dir);
            const double z = point_camera.z();
            // Noise along the ray, growing with z² like a structured-light sensor.
            point_camera *= 1.0 + params.depth_noise * z * n;
            cloud.points.push_back(point_camera.cast<float>());
            cloud.source_index.push_back(v * params.width + u);
        }
    }
    if (cloud.empty()) throw Error("procedural scene", "no ray hit the table");

    // One structure per object: the outer box is the object's box (in the camera frame) grown by
    // 10 cm on every side, the fovea is the object's box itself.
    scene.fovea.downsample = Downsample::voxel;
    for (const Primitive& primitive : primitives) {
        const Box object_table = bounds_of(primitive);
        // Bound the object's box corners in the camera frame.
        Box object_camera = bounding_box(std::span<const Point>());
        Box outer_camera = object_camera;
        for (int corner = 0; corner < 8; ++corner) {
            const Eigen::Vector3f sel((corner & 1) ? 1.f : 0.f, (corner & 2) ? 1.f : 0.f, (corner & 4) ? 1.f : 0.f);
            const Eigen::Vector3f c = object_table.min + sel.cwiseProduct(object_table.size());
            const Point pc = (table_to_camera * (c.cast<double>() - eye)).cast<float>();
            object_camera.extend(pc);
        }
        outer_camera.min = object_camera.min.array() - 0.10f;
        outer_camera.max = object_camera.max.array() + 0.10f;
        scene.fovea.structures.push_back(structure_between(outer_camera, object_camera, params.levels, LevelDetail{}));

        const char* shape = primitive.kind == Primitive::Kind::box        ? "box"
                            : primitive.kind == Primitive::Kind::cylinder ? "cylinder"
                                                                          : "sphere";
        scene.objects.push_back({shape, object_camera});
    }
    return scene;
}

}  // namespace mfpc
