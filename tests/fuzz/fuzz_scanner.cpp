// The virtual scanner (`mfpc synth`, Embree) on a fuzzed scene: one shape, a fuzzed triangle mesh
// (up to 64 vertices and 64 triangles) or fuzzed oriented discs, placed by a fuzzed pose, with or
// without the table plane, seen by a 64 x 48 sensor from a fuzzed eye. Asserts the scan is an
// organized image of the sensor's size with finite points within the sensor's range, labels that
// agree with the points, and visible counts that add up.
#include <vector>

#include "fuzz_support.hpp"
#include "mfpc/simulation/virtual_scanner.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    fuzz::Bytes bytes(data, size);
    const int flags = bytes.byte();
    SyntheticScene scene;
    SceneShape shape;
    shape.name = "fuzzed";
    const int count = bytes.in(3, 64);
    if (flags & 1) {
        shape.discs.width = 0;
        for (int i = 0; i < count; ++i) {
            shape.discs.points.emplace_back(bytes.grid(-0.2f, 0.2f, 32), bytes.grid(-0.2f, 0.2f, 32), bytes.grid(0, 0.3f, 24));
            shape.discs.normals.emplace_back(bytes.grid(-1, 1, 4), bytes.grid(-1, 1, 4), bytes.grid(-1, 1, 4));
        }
        shape.discs.width = std::uint32_t(shape.discs.size());
        shape.disc_radius = bytes.grid(0.001f, 0.02f, 19);
    } else {
        for (int i = 0; i < count; ++i) {
            shape.mesh.vertices.emplace_back(bytes.grid(-0.2f, 0.2f, 32), bytes.grid(-0.2f, 0.2f, 32), bytes.grid(0, 0.3f, 24));
        }
        const int triangles = bytes.in(1, 64);
        for (int i = 0; i < triangles; ++i) {
            shape.mesh.triangles.emplace_back(bytes.in(0, count - 1), bytes.in(0, count - 1), bytes.in(0, count - 1));
        }
    }
    scene.shapes.push_back(shape);
    SceneObject object;
    object.pose = Eigen::Translation3f(bytes.grid(-0.3f, 0.3f, 12), bytes.grid(-0.3f, 0.3f, 12), 0) *
                  Eigen::AngleAxisf(bytes.grid(-3.14159f, 3.14159f, 32), Eigen::Vector3f::UnitZ());
    scene.objects.push_back(object);
    if (flags & 2) scene.plane_half_size = Eigen::Vector2f::Zero();
    const Eigen::Vector3f eye(bytes.grid(-1.5f, 1.5f, 12), bytes.grid(-1.5f, 1.5f, 12), bytes.grid(0.2f, 2, 12));
    SensorParams sensor;
    sensor.width = 64;
    sensor.height = 48;
    sensor.noise_at_1m = flags & 4 ? 0.0f : 0.0015f;
    sensor.disparity_subpixel = flags & 8 ? 0 : 8;
    fuzz::run([&] {
        scene.camera = camera_looking_at(eye, Eigen::Vector3f::Zero());
        fuzz::check(scene.camera.matrix().allFinite(), "camera_looking_at gave a non-finite pose");
        const Scan scan = scan_scene(scene, sensor, bytes.u32());
        fuzz::check(scan.cloud.width == sensor.width && scan.cloud.height == sensor.height, "the scan is not the sensor's image");
        fuzz::check(scan.labels.size() == std::size_t(sensor.width) * sensor.height, "labels are not one per pixel");
        fuzz::check(scan.visible_points.size() == scene.objects.size(), "visible points are not one count per object");
        std::size_t object_returns = 0;
        std::vector<bool> seen(scan.labels.size(), false);
        for (std::size_t i = 0; i < scan.cloud.size(); ++i) {
            const Point& p = scan.cloud.points[i];
            fuzz::check(fuzz::finite(p), "a scanned point is not finite");
            // The range bounds depth; disparity rounding and noise move it a little.
            fuzz::check(p.z() >= sensor.min_range * 0.9f && p.z() <= sensor.max_range * 1.1f, "a scanned point out of range");
            const std::uint32_t pixel = scan.cloud.source_position(i);
            fuzz::check(pixel < scan.labels.size() && !seen[pixel], "two points on one pixel");
            seen[pixel] = true;
            fuzz::check(scan.labels[pixel] != label_none, "a point on a pixel labelled no return");
            if (scan.labels[pixel] >= label_first_object) ++object_returns;
        }
        std::size_t visible = 0;
        for (std::size_t v : scan.visible_points) visible += v;
        fuzz::check(visible == object_returns, "visible points do not add up to the objects' returns");
    });
    return 0;
}
