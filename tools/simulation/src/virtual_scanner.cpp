#include "mfpc/simulation/virtual_scanner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/rendering/detail/embree_handles.hpp"
#include "mfpc/core/error.hpp"

namespace mfpc {

std::span<const Eigen::Vector3f> outline(const SceneShape& shape)
{
    return shape.mesh.empty() ? std::span<const Eigen::Vector3f>(shape.discs.points)
                              : std::span<const Eigen::Vector3f>(shape.mesh.vertices);
}

float footprint_radius(const SceneShape& shape)
{
    float radius = 0;
    for (const Eigen::Vector3f& p : outline(shape)) radius = std::max(radius, std::hypot(p.x(), p.y()));
    return radius;
}

Box shape_bounds(const SceneShape& shape) { return bounding_box(outline(shape)); }

Pose camera_looking_at(const Eigen::Vector3f& eye, const Eigen::Vector3f& target)
{
    const Eigen::Vector3f forward = (target - eye).normalized();
    Eigen::Vector3f right = forward.cross(Eigen::Vector3f::UnitZ());
    // Straight down (or up) the heading is undefined: take the world's x as right.
    right = right.squaredNorm() > 1e-12f ? right.normalized() : Eigen::Vector3f::UnitX();
    const Eigen::Vector3f down = forward.cross(right);
    Pose camera = Pose::Identity();
    camera.linear().col(0) = right;
    camera.linear().col(1) = down;
    camera.linear().col(2) = forward;
    camera.translation() = eye;
    return camera;
}


Camera SensorParams::camera() const
{
    Camera camera;
    camera.width = width;
    camera.height = height;
    camera.fx = camera.fy = focal_length > 0 ? focal_length : 525.0f * float(width) / 640.0f;
    camera.cx = 0.5f * float(width - 1);
    camera.cy = 0.5f * float(height - 1);
    return camera;
}

void check_sensor(const SensorParams& sensor)
{
    constexpr std::uint32_t max_side = 16384;
    auto fail = [](const char* field, const std::string& reason) { throw Error(std::string("sensor.") + field, reason); };
    if (sensor.width == 0 || sensor.height == 0 || sensor.width > max_side || sensor.height > max_side) {
        fail("resolution", std::to_string(sensor.width) + "x" + std::to_string(sensor.height) +
                               " is outside 1x1 .. " + std::to_string(max_side) + "x" + std::to_string(max_side));
    }
    if (!(sensor.focal_length >= 0) || !std::isfinite(sensor.focal_length))
        fail("focal_length", "must be positive (or 0 for the Kinect's field of view)");
    // A field of view near 180 degrees sends rays along the image plane (directions of 1e17 and
    // more stop Embree outright) and images nothing a depth sensor could: 170 degrees at most.
    const float half_side = 0.5f * float(std::max(sensor.width, sensor.height));
    const float widest = half_side / std::tan(85.0f * std::numbers::pi_v<float> / 180.0f);
    if (sensor.focal_length > 0 && sensor.focal_length < widest) {
        fail("focal_length", format_number(sensor.focal_length) + " pixels gives a field of view above 170 degrees at " +
                                 std::to_string(sensor.width) + "x" + std::to_string(sensor.height) +
                                 ": use at least " + format_number(widest) + " (or 0 for the Kinect's)");
    }
    if (!(sensor.noise_at_1m >= 0) || !std::isfinite(sensor.noise_at_1m)) fail("noise_at_1m", "must be >= 0");
    if (!(sensor.baseline > 0) || !std::isfinite(sensor.baseline)) fail("baseline", "must be positive");
    if (sensor.disparity_subpixel < 0) fail("disparity_subpixel", "must be >= 0 (0: no quantization)");
    if (!(sensor.max_incidence_deg > 0 && sensor.max_incidence_deg <= 90))
        fail("max_incidence_deg", "must lie in (0, 90]");
    if (!(sensor.min_range >= 0 && sensor.min_range < sensor.max_range) || !std::isfinite(sensor.max_range))
        fail("range", "needs 0 <= min_range < max_range (finite)");
}

namespace {

// A counter-based generator: a pixel's noise depends on (seed, pixel) only, never on which thread
// casts it or in what order.
std::uint64_t mix(std::uint64_t x)
{
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

double standard_normal(std::uint32_t seed, std::uint64_t pixel)
{
    const std::uint64_t bits = mix(mix(seed) ^ pixel);
    // Two 32-bit uniforms in (0, 1] and [0, 1), Box-Muller.
    const double u1 = (double(bits >> 32) + 1.0) / 4294967296.0;
    const double u2 = double(bits & 0xFFFFFFFFull) / 4294967296.0;
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

void set_triangles(RTCDevice device, RTCGeometry geometry, std::span<const Eigen::Vector3f> vertices,
                   std::span<const Eigen::Vector3i> triangles)
{
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), vertices.size()));
    auto* t = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(unsigned), triangles.size()));
    embree::check(device, "mesh buffers");
    for (std::size_t i = 0; i < vertices.size(); ++i)
        for (int a = 0; a < 3; ++a) v[3 * i + std::size_t(a)] = vertices[i][a];
    for (std::size_t i = 0; i < triangles.size(); ++i) {
        for (int a = 0; a < 3; ++a) {
            const int index = triangles[i][a];
            if (index < 0 || std::size_t(index) >= vertices.size())
                throw Error("scanner", "triangle " + std::to_string(i) + " has vertex index " + std::to_string(index) +
                                           " out of range");
            t[3 * i + std::size_t(a)] = unsigned(index);
        }
    }
}

}  // namespace

struct VirtualScanner::Impl {
    embree::Device device;
    embree::Scene scene;
    std::size_t objects = 0;
};

VirtualScanner::VirtualScanner(const SyntheticScene& scene) : impl_(std::make_unique<Impl>())
{
    impl_->device = embree::make_device();
    RTCDevice device = impl_->device.get();
    impl_->scene = embree::make_scene(device);
    RTCScene rtc_scene = impl_->scene.get();
    impl_->objects = scene.objects.size();
    if (scene.objects.size() + 1 > std::size_t(std::numeric_limits<std::uint16_t>::max()) - label_first_object)
        throw Error("scanner", "too many objects (" + std::to_string(scene.objects.size()) + ")");

    // Geometry IDs are label - 1: the plane is 0, object i is i + 1, so a hit's label is geomID + 1.
    const Pose world_to_camera = scene.camera.inverse();
    auto attach = [&](embree::Geometry geometry, unsigned id, const std::string& what) {
        rtcCommitGeometry(geometry.get());
        rtcAttachGeometryByID(rtc_scene, geometry.get(), id);
        embree::check(device, what);
    };

    if (scene.plane_half_size.x() > 0 && scene.plane_half_size.y() > 0) {
        const float hx = scene.plane_half_size.x();
        const float hy = scene.plane_half_size.y();
        const Eigen::Vector3f corners[4] = {world_to_camera * Eigen::Vector3f(-hx, -hy, 0),
                                            world_to_camera * Eigen::Vector3f(hx, -hy, 0),
                                            world_to_camera * Eigen::Vector3f(hx, hy, 0),
                                            world_to_camera * Eigen::Vector3f(-hx, hy, 0)};
        const Eigen::Vector3i triangles[2] = {{0, 1, 2}, {0, 2, 3}};
        embree::Geometry geometry(rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE));
        set_triangles(device, geometry.get(), corners, triangles);
        attach(std::move(geometry), 0, "support plane");
    }

    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const SceneObject& object = scene.objects[i];
        if (object.shape >= scene.shapes.size())
            throw Error("scanner", "object " + std::to_string(i) + " names shape " + std::to_string(object.shape) +
                                       " of " + std::to_string(scene.shapes.size()));
        const SceneShape& shape = scene.shapes[object.shape];
        const Pose to_camera = world_to_camera * object.pose;
        const std::string what = "object " + std::to_string(i) + " (" + shape.name + ")";
        if (!shape.mesh.empty()) {
            std::vector<Eigen::Vector3f> vertices(shape.mesh.vertices.size());
            for (std::size_t v = 0; v < vertices.size(); ++v) vertices[v] = to_camera * shape.mesh.vertices[v];
            embree::Geometry geometry(rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE));
            set_triangles(device, geometry.get(), vertices, shape.mesh.triangles);
            attach(std::move(geometry), unsigned(i + 1), what);
        } else {
            const PointCloud& discs = shape.discs;
            if (discs.empty() || !discs.has_normals() || !(shape.disc_radius > 0))
                throw Error("scanner", what + " has neither a mesh nor discs with normals and a radius");
            embree::Geometry geometry(rtcNewGeometry(device, RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT));
            auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geometry.get(), RTC_BUFFER_TYPE_VERTEX, 0,
                                                                  RTC_FORMAT_FLOAT4, 4 * sizeof(float), discs.size()));
            auto* n = static_cast<float*>(rtcSetNewGeometryBuffer(geometry.get(), RTC_BUFFER_TYPE_NORMAL, 0,
                                                                  RTC_FORMAT_FLOAT3, 3 * sizeof(float), discs.size()));
            embree::check(device, what);
            for (std::size_t p = 0; p < discs.size(); ++p) {
                const Eigen::Vector3f position = to_camera * discs.points[p];
                Eigen::Vector3f normal = to_camera.linear() * discs.normals[p];
                // A disc without a normal still occludes: it faces the sensor.
                if (!normal.allFinite() || normal.squaredNorm() == 0) normal = -position.normalized();
                for (int a = 0; a < 3; ++a) {
                    v[4 * p + std::size_t(a)] = position[a];
                    n[3 * p + std::size_t(a)] = normal[a];
                }
                v[4 * p + 3] = shape.disc_radius;
            }
            attach(std::move(geometry), unsigned(i + 1), what);
        }
    }
    rtcCommitScene(rtc_scene);
    embree::check(device, "scene build");
}

VirtualScanner::~VirtualScanner() = default;
VirtualScanner::VirtualScanner(VirtualScanner&&) noexcept = default;
VirtualScanner& VirtualScanner::operator=(VirtualScanner&&) noexcept = default;

Scan VirtualScanner::scan(const SensorParams& sensor, std::uint32_t seed) const
{
    check_sensor(sensor);
    const Camera camera = sensor.camera();
    const std::uint32_t width = sensor.width;
    const std::uint32_t height = sensor.height;
    const std::size_t pixels = std::size_t(width) * height;

    const double bf = double(sensor.baseline) * camera.fx;  // disparity (pixels) times depth
    const double sigma_disparity = double(sensor.noise_at_1m) * bf;
    const double subpixel = sensor.disparity_subpixel;
    const float min_cos = float(std::cos(double(sensor.max_incidence_deg) * std::numbers::pi / 180.0));
    const float nan = std::numeric_limits<float>::quiet_NaN();

    std::vector<Point> grid(pixels);
    Scan scan;
    scan.camera = camera;
    scan.labels.assign(pixels, label_none);
    RTCScene rtc_scene = impl_->scene.get();

    // What the sensor makes of a ray through pixel (u, v) that met geometry `geometry` at distance
    // t along (direction, z = 1), with geometric normal `normal`.
    auto record = [&](std::uint32_t u, std::uint32_t v, float t, unsigned geometry, const Eigen::Vector3f& normal) {
        const std::size_t pixel = std::size_t(v) * width + u;
        grid[pixel] = Point::Constant(nan);
        if (geometry == RTC_INVALID_GEOMETRY_ID) return;
        const Eigen::Vector3f d((float(u) - camera.cx) / camera.fx, (float(v) - camera.cy) / camera.fy, 1.0f);
        if (std::abs(normal.dot(d)) < min_cos * normal.norm() * d.norm()) return;
        // z = 1 along the ray, so the hit distance t is the depth.
        double depth = t;
        double disparity = bf / depth;
        if (sigma_disparity > 0) disparity += sigma_disparity * standard_normal(seed, pixel);
        if (subpixel > 0) disparity = std::round(disparity * subpixel) / subpixel;
        if (!(disparity > 0)) return;
        depth = bf / disparity;
        if (depth < sensor.min_range || depth > sensor.max_range) return;
        const float z = float(depth);
        grid[pixel] = Point(d.x() * z, d.y() * z, z);
        scan.labels[pixel] = std::uint16_t(geometry + 1);
    };

    // Packets of 8 neighbouring pixels of a row: primary rays from one origin are coherent, which
    // Embree's packet traversal exploits. Packets never straddle rows, so the grouping (and with it
    // every result) is the same for any thread count.
    constexpr std::uint32_t lanes = 8;
    tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, height, 4), [&](const tbb::blocked_range<std::uint32_t>& rows) {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        RTCRayHit8 packet;
        int valid[lanes];
        for (std::uint32_t v = rows.begin(); v != rows.end(); ++v) {
            for (std::uint32_t u0 = 0; u0 < width; u0 += lanes) {
                for (std::uint32_t lane = 0; lane < lanes; ++lane) {
                    const std::uint32_t u = u0 + lane;
                    valid[lane] = u < width ? -1 : 0;
                    packet.ray.org_x[lane] = packet.ray.org_y[lane] = packet.ray.org_z[lane] = 0.0f;
                    packet.ray.dir_x[lane] = (float(u) - camera.cx) / camera.fx;
                    packet.ray.dir_y[lane] = (float(v) - camera.cy) / camera.fy;
                    packet.ray.dir_z[lane] = 1.0f;
                    packet.ray.tnear[lane] = 0.0f;
                    packet.ray.tfar[lane] = std::numeric_limits<float>::infinity();
                    packet.ray.time[lane] = 0.0f;
                    packet.ray.mask[lane] = 0xFFFFFFFFu;
                    packet.ray.id[lane] = lane;
                    packet.ray.flags[lane] = 0;
                    packet.hit.geomID[lane] = RTC_INVALID_GEOMETRY_ID;
                    packet.hit.instID[0][lane] = RTC_INVALID_GEOMETRY_ID;
                }
                rtcIntersect8(valid, rtc_scene, &context, &packet);
                for (std::uint32_t lane = 0; lane < lanes && u0 + lane < width; ++lane) {
                    record(u0 + lane, v, packet.ray.tfar[lane], packet.hit.geomID[lane],
                           Eigen::Vector3f(packet.hit.Ng_x[lane], packet.hit.Ng_y[lane], packet.hit.Ng_z[lane]));
                }
            }
        }
    });

    PointCloud& cloud = scan.cloud;
    cloud.width = width;
    cloud.height = height;
    scan.visible_points.assign(impl_->objects, 0);
    std::size_t returns = 0;
    for (std::uint16_t label : scan.labels) returns += label != label_none;
    cloud.points.reserve(returns);
    cloud.source_index.reserve(returns);
    for (std::size_t pixel = 0; pixel < pixels; ++pixel) {
        const std::uint16_t label = scan.labels[pixel];
        if (label == label_none) continue;
        cloud.points.push_back(grid[pixel]);
        cloud.source_index.push_back(std::uint32_t(pixel));
        if (label >= label_first_object) ++scan.visible_points[label - label_first_object];
    }
    return scan;
}

}  // namespace mfpc
