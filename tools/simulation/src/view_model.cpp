#include "mfpc/simulation/view_model.hpp"

#include <cmath>
#include <numbers>
#include <optional>

#include "mfpc/core/camera.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/index/organized_neighbors.hpp"
#include "mfpc/kernels/uniform_sampling.hpp"
#include "mfpc/recognition/features.hpp"
#include "mfpc/simulation/virtual_scanner.hpp"

namespace mfpc {

Model prepare_view_model(const SceneShape& shape, const PointCloud& surface, const FeatureParams& params,
                         const ViewModelParams& views, FeatureTimings* timings)
{
    if (views.headings < 1 || views.elevations_deg.empty())
        throw Error(shape.name, "a view model needs at least one heading and one elevation");
    if (surface.empty() || !surface.has_normals())
        throw Error(shape.name, "the model's surface cloud needs points and normals");

    SyntheticScene scene;
    scene.shapes = {shape};
    scene.objects.push_back(SceneObject{});
    scene.plane_half_size = Eigen::Vector2f::Zero();
    const Eigen::Vector3f target(0, 0, shape_bounds(shape).center().z());

    Model model;
    model.points = surface.points;
    model.normals = surface.normals;
    model.params = params;
    model.source = shape.name + " (" + std::to_string(views.headings * int(views.elevations_deg.size())) + " views)";
    std::uint32_t view_index = 0;
    for (float elevation_deg : views.elevations_deg) {
        for (int h = 0; h < views.headings; ++h, ++view_index) {
            const double heading = 2.0 * std::numbers::pi * h / views.headings;
            const double elevation = double(elevation_deg) * std::numbers::pi / 180.0;
            const Eigen::Vector3f eye =
                target + views.distance * Eigen::Vector3f(float(std::cos(elevation) * std::cos(heading)),
                                                          float(std::cos(elevation) * std::sin(heading)),
                                                          float(std::sin(elevation)));
            scene.camera = camera_looking_at(eye, target);
            const Scan scan = scan_scene(scene, views.sensor, views.seed + view_index);
            if (scan.cloud.size() < 3) continue;
            const auto& points = scan.cloud.points;
            auto as_sampled = [&] {
                const auto keypoints = uniform_sampling(points, params.keypoint_radius);
                // The scan's neighbours in its depth image, with a fitted camera rather than the
                // scanner's: the points sit a rounding error off their pixels, and the fit measures
                // how far, which the image search's bounds must allow for.
                if (const std::optional<Camera> fitted = fit_camera(scan.cloud))
                    return describe_keypoints(points, keypoints,
                                              OrganizedNeighbors(scan.cloud, *fitted, 3, normal_grid_cell), params,
                                              timings);
                return describe_keypoints(points, keypoints, NeighborGrid(points, normal_grid_cell), params, timings);
            };
            const Features view =
                params.resolution > 0.0f ? describe_at_resolution(points, params, timings) : as_sampled();

            // Into the object's frame: keypoints by the camera pose, frame axes (rows) by its rotation.
            const Eigen::Matrix3f rotation = scene.camera.linear();
            Features& all = model.features;
            for (std::size_t i = 0; i < view.size(); ++i) {
                all.keypoints.push_back(scene.camera * view.keypoints[i]);
                all.frames.push_back(view.frames[i] * rotation.transpose());
            }
            all.descriptors.insert(all.descriptors.end(), view.descriptors.begin(), view.descriptors.end());
            all.candidates += view.candidates;
            all.invalid += view.invalid;
        }
    }
    require_model_keypoints(model.features, params, shape.name);
    return model;
}

}  // namespace mfpc
