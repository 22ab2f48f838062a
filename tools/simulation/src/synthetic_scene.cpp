#include "mfpc/simulation/synthetic_scene.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <limits>
#include <random>

#include <nlohmann/json.hpp>

#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/kernels/normals.hpp"
#include "mfpc/rendering/png_image.hpp"
#include "mfpc/simulation/view_model.hpp"
#include "synthetic_files.hpp"

namespace mfpc {

namespace detail {

std::string file_safe(const std::string& name)
{
    std::string safe = name.empty() ? std::string("object") : name;
    for (char& c : safe)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.')) c = '_';
    for (const char* reserved : {"scene", "labels", "fovea", "scene.gt"})
        if (safe == reserved) safe += "_model";
    return safe;
}

std::vector<std::string> model_cloud_files(const SyntheticScene& scene)
{
    std::vector<std::string> files;
    for (std::size_t s = 0; s < scene.shapes.size(); ++s) {
        std::string file = file_safe(scene.shapes[s].name) + ".pcd";
        // Two shapes of one name (a file named like a built-in) get distinct files.
        if (std::find(files.begin(), files.end(), file) != files.end())
            file = file_safe(scene.shapes[s].name) + "_" + std::to_string(s) + ".pcd";
        files.push_back(file);
    }
    return files;
}

std::string model_cache_file(const SyntheticScene& scene) { return file_safe(scene.shapes.at(0).name) + ".mfpcm"; }

void check_camera_reach(const SyntheticScene& scene, const SensorParams& sensor)
{
    float nearest = std::numeric_limits<float>::infinity();
    for (const SceneObject& object : scene.objects)
        nearest = std::min(nearest, (scene.camera.translation() - object.pose.translation()).norm());
    if (nearest > sensor.max_range)
        throw Error("synth", "the objects need the camera " + format_number(std::round(nearest * 100.0f) / 100.0f) +
                                 " m away, beyond max_range " + format_number(sensor.max_range) +
                                 " m: place fewer objects or raise max_range");
}

std::vector<PointCloud> model_clouds(const SyntheticScene& scene, float model_spacing)
{
    std::vector<PointCloud> models;
    for (const SceneShape& shape : scene.shapes) {
        // A fixed sampling seed: a shape's model cloud is the same file in every scene.
        models.push_back(shape.mesh.empty() ? shape.discs : sample_surface(shape.mesh, model_spacing, 1));
    }
    return models;
}

Model describe_object(const SyntheticScene& scene, const PointCloud& surface, const FeatureParams& features,
                      const SensorParams& sensor)
{
    Model model = prepare_view_model(scene.shapes.at(0), surface, features, view_model_params(sensor));
    model.source = model_cloud_files(scene).at(0);
    return model;
}

std::string json_file_text(const nlohmann::ordered_json& json)
{
    return json.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + '\n';
}

void write_json_file(const std::filesystem::path& path, const nlohmann::ordered_json& json)
{
    const std::string text = json_file_text(json);
    write_file_atomically(path, [&](std::ofstream& out) { out << text; });
}

}  // namespace detail

using detail::file_safe;
using detail::write_json_file;

namespace {

std::string lower_extension(const std::filesystem::path& path)
{
    std::string extension = path.extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return extension;
}

float median_nearest_distance(std::span<const Point> points, const NeighborGrid& grid)
{
    // A strided sample is plenty for a median.
    const std::size_t step = std::max<std::size_t>(1, points.size() / 2000);
    std::vector<float> distances;
    std::vector<std::uint32_t> indices;
    std::vector<float> squared;
    for (std::size_t i = 0; i < points.size(); i += step) {
        grid.knn_search(points[i], 2, indices, squared);
        if (squared.size() == 2 && squared[1] > 0) distances.push_back(std::sqrt(squared[1]));
    }
    if (distances.empty()) return 0;
    std::nth_element(distances.begin(), distances.begin() + std::ptrdiff_t(distances.size() / 2), distances.end());
    return distances[distances.size() / 2];
}

nlohmann::ordered_json pose_json(const Pose& pose)
{
    const auto values = pose_to_row_major(pose);
    return nlohmann::ordered_json(std::vector<double>(values.begin(), values.end()));
}

}  // namespace

SceneShape make_builtin_shape(const std::string& name)
{
    SceneShape shape;
    shape.name = name;
    shape.mesh = make_builtin_object(name);
    shape.symmetry_order = builtin_object_symmetry(name);
    shape.symmetry_flip = builtin_object_flips(name);
    return shape;
}

std::vector<SceneShape> builtin_scene_shapes(const std::string& first)
{
    std::vector<SceneShape> shapes{make_builtin_shape(first)};
    for (std::string_view name : builtin_object_names())
        if (name != first) shapes.push_back(make_builtin_shape(std::string(name)));
    return shapes;
}

SceneShape make_cloud_shape(const PointCloud& cloud, const std::string& name, const Eigen::Vector3f& up)
{
    check_cloud(cloud, name.c_str());
    if (cloud.size() < 3) throw Error(name, "a cloud model needs at least 3 points, it has " + std::to_string(cloud.size()));
    if (!(up.squaredNorm() > 0) || !up.allFinite()) throw Error(name, "the up direction must be a non-zero vector");

    // The grid cell is a few point spacings, the spacing estimated from the bounding box as if the
    // points covered about half its surface.
    const Box bounds = bounding_box(cloud.points);
    const Eigen::Vector3f extent = bounds.size().cwiseMax(1e-6f);
    const double half_surface = double(extent.x()) * extent.y() + double(extent.y()) * extent.z() +
                                double(extent.z()) * extent.x();
    const float cell = float(3.0 * std::sqrt(half_surface / double(cloud.size())));
    const NeighborGrid grid(cloud.points, std::max(cell, 1e-6f));

    SceneShape shape;
    shape.name = name;
    shape.disc_radius = median_nearest_distance(cloud.points, grid);
    if (!(shape.disc_radius > 0)) throw Error(name, "the cloud's points all lie at one spot");

    std::vector<Point> normals = cloud.normals;
    if (normals.empty()) {
        normals.resize(cloud.size());
        estimate_normals(cloud.points, grid, NormalParams{}, normals);
    }

    const Eigen::Matrix3f rotation =
        Eigen::Quaternionf::FromTwoVectors(up.normalized(), Eigen::Vector3f::UnitZ()).toRotationMatrix();
    PointCloud& discs = shape.discs;
    discs.width = std::uint32_t(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        // Discs without a normal cannot be drawn oriented; they are few (isolated points).
        if (!normals[i].allFinite()) continue;
        discs.points.push_back(rotation * cloud.points[i]);
        discs.normals.push_back(rotation * normals[i]);
    }
    if (discs.points.size() < 3) throw Error(name, "too few points with a defined normal");
    discs.width = std::uint32_t(discs.points.size());
    const Box rotated = bounding_box(discs.points);
    const Eigen::Vector3f shift(-rotated.center().x(), -rotated.center().y(), -rotated.min.z());
    for (Point& p : discs.points) p += shift;
    return shape;
}

SceneShape load_shape(const std::string& name_or_path, const Eigen::Vector3f& cloud_up)
{
    if (is_builtin_object(name_or_path)) return make_builtin_shape(name_or_path);
    const std::filesystem::path path(name_or_path);
    const std::string extension = lower_extension(path);
    const std::string name = file_safe(path.stem().string());
    if (extension == ".pcd") return make_cloud_shape(read_cloud(path), name, cloud_up);
    if (extension == ".ply" || extension == ".obj") {
        SceneShape shape;
        shape.name = name;
        shape.mesh = read_mesh(path);
        return shape;
    }
    std::string known;
    for (std::string_view builtin : builtin_object_names()) known += std::string(known.empty() ? "" : ", ") + std::string(builtin);
    throw Error(name_or_path, "not a built-in object (" + known + ") nor a .ply/.obj mesh or .pcd cloud");
}

SyntheticScene compose_scene(std::vector<SceneShape> shapes, const ComposeParams& params)
{
    if (shapes.empty()) throw Error("synth", "no object shape to place");
    if (params.distractors > 0 && shapes.size() < 2)
        throw Error("synth", "distractors need at least one distractor shape");
    if (std::size_t(params.objects) + params.distractors == 0) throw Error("synth", "nothing to place: 0 objects and 0 distractors");
    if (!(params.camera_distance_min > 0 && params.camera_distance_min <= params.camera_distance_max) ||
        !(params.camera_elevation_min_deg > 0 && params.camera_elevation_min_deg <= params.camera_elevation_max_deg &&
          params.camera_elevation_max_deg <= 90) ||
        !(params.placement_half_x > 0 && params.placement_half_y > 0 && params.gap >= 0))
        throw Error("synth", "contradictory compose parameters (distances, elevations, placement area or gap)");

    SyntheticScene scene;
    scene.shapes = std::move(shapes);
    // libstdc++'s distributions: the same seed gives the same scene with the same standard library
    // (as the procedural scene of foveate --procedural).
    std::mt19937 rng(params.seed);
    auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };

    std::vector<std::size_t> kinds(params.objects, 0);
    for (std::uint32_t i = 0; i < params.distractors; ++i)
        kinds.push_back(1 + std::uniform_int_distribution<std::size_t>(0, scene.shapes.size() - 2)(rng));

    std::vector<float> radius(scene.shapes.size());
    for (std::size_t s = 0; s < scene.shapes.size(); ++s) radius[s] = footprint_radius(scene.shapes[s]);
    double needed = 0;
    for (std::size_t kind : kinds) needed += std::numbers::pi * std::pow(radius[kind] + params.gap, 2);
    // Random sequential placement of discs jams above about half coverage: aim at 40%.
    double scale = std::max(1.0, std::sqrt(needed / 0.4 / (4.0 * params.placement_half_x * params.placement_half_y)));

    std::vector<Eigen::Vector2f> centres;
    for (int attempt = 0;; ++attempt) {
        const double hx = params.placement_half_x * scale;
        const double hy = params.placement_half_y * scale;
        centres.clear();
        bool placed_all = true;
        for (std::size_t kind : kinds) {
            const double r = radius[kind];
            bool placed = false;
            for (int trial = 0; trial < 500 && !placed; ++trial) {
                const Eigen::Vector2f c(float(uniform(-hx + r, std::max(-hx + r, hx - r) + 1e-9)),
                                        float(uniform(-hy + r, std::max(-hy + r, hy - r) + 1e-9)));
                placed = true;
                for (std::size_t j = 0; j < centres.size() && placed; ++j)
                    placed = (c - centres[j]).norm() >= r + radius[kinds[j]] + params.gap;
                if (placed) centres.push_back(c);
            }
            if (!placed) {
                placed_all = false;
                break;
            }
        }
        if (placed_all) break;
        if (attempt == 50) throw Error("synth", "cannot place the objects without overlap");
        scale *= 1.1;  // crowded: the same draw sequence goes on in a larger area
    }

    for (std::size_t i = 0; i < kinds.size(); ++i) {
        SceneObject object;
        object.shape = kinds[i];
        object.distractor = i >= params.objects;
        object.pose = Pose::Identity();
        object.pose.linear() = Eigen::AngleAxisf(float(uniform(0.0, 2.0 * std::numbers::pi)), Eigen::Vector3f::UnitZ())
                                   .toRotationMatrix();
        object.pose.translation() = Eigen::Vector3f(centres[i].x(), centres[i].y(), 0.0f);
        scene.objects.push_back(object);
    }
    const Eigen::Vector3f centre = objects_centre(scene);

    const double heading = uniform(0.0, 2.0 * std::numbers::pi);
    const double elevation = uniform(params.camera_elevation_min_deg, params.camera_elevation_max_deg) *
                             std::numbers::pi / 180.0;
    const double distance = uniform(params.camera_distance_min, params.camera_distance_max) * scale;
    const Eigen::Vector3f eye =
        centre + float(distance) * Eigen::Vector3f(float(std::cos(elevation) * std::cos(heading)),
                                                   float(std::cos(elevation) * std::sin(heading)),
                                                   float(std::sin(elevation)));
    scene.camera = camera_looking_at(eye, centre);
    // The table reaches well past the objects so that they stand on it in every view.
    scene.plane_half_size = Eigen::Vector2f(float(params.placement_half_x * scale + 0.3),
                                            float(params.placement_half_y * scale + 0.3));
    return scene;
}

Eigen::Vector3f objects_centre(const SyntheticScene& scene)
{
    Eigen::Vector3f centre = Eigen::Vector3f::Zero();
    for (const SceneObject& object : scene.objects)
        centre += Eigen::Vector3f(object.pose.translation().x(), object.pose.translation().y(), 0.0f);
    if (!scene.objects.empty()) centre /= float(scene.objects.size());
    centre.z() = 0.08f;  // look at mid-height of a typical object, not at its foot
    return centre;
}

Box object_box_in_camera(const SyntheticScene& scene, std::size_t index)
{
    const SceneObject& object = scene.objects.at(index);
    const Pose to_camera = scene.camera.inverse() * object.pose;
    Box box = bounding_box({});
    for (const Eigen::Vector3f& p : outline(scene.shapes.at(object.shape))) {
        const Eigen::Vector3f q = to_camera * p;
        box.extend(q);
    }
    return box;
}

namespace {

// A structure around `object` (camera frame): the fovea is the box grown by 1 cm, the outer box
// grown by 11 cm; the densities and radii of the shipped milk-carton configs.
FoveatedStructure structure_around(const Box& object, int levels, const std::string& name)
{
    const Box outer{object.min.array() - 0.11f, object.max.array() + 0.11f};
    const Box fovea{object.min.array() - 0.01f, object.max.array() + 0.01f};
    return structure_between(outer, fovea, levels, LevelDetail{}, name);
}

}  // namespace

FoveationConfig fovea_per_instance(const SyntheticScene& scene)
{
    constexpr int levels = 3;
    FoveationConfig config;
    config.downsample = Downsample::voxel;
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        if (scene.objects[i].distractor) continue;
        config.structures.push_back(structure_around(object_box_in_camera(scene, i), levels,
                                                     scene.shapes[scene.objects[i].shape].name + " " + std::to_string(i)));
    }
    return config;
}

FoveationConfig fovea_covering_all(const SyntheticScene& scene)
{
    constexpr int levels = 3;
    FoveationConfig config;
    config.downsample = Downsample::voxel;
    Box all = bounding_box({});
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        if (scene.objects[i].distractor) continue;
        const Box object = object_box_in_camera(scene, i);
        all.extend(object);
    }
    if (all.valid()) config.structures.push_back(structure_around(all, levels, "all instances"));
    return config;
}

ViewModelParams view_model_params(const SensorParams& sensor)
{
    // The views keep the scene's noise model, at VGA (they need not follow a scaling study's
    // resolution) and the default range, which their 1 m distance lies in whatever the scene's.
    ViewModelParams views;
    views.sensor.noise_at_1m = sensor.noise_at_1m;
    views.sensor.baseline = sensor.baseline;
    views.sensor.disparity_subpixel = sensor.disparity_subpixel;
    views.sensor.max_incidence_deg = sensor.max_incidence_deg;
    return views;
}

std::vector<float> visible_fraction_of(const SyntheticScene& scene, const Scan& scan, const SensorParams& sensor,
                                       std::uint32_t seed)
{
    SensorParams wide = sensor;
    wide.focal_length = scan.camera.fx;
    wide.width = sensor.width * 2;
    wide.height = sensor.height * 2;
    std::vector<float> fractions(scene.objects.size(), -1.0f);
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        if (scene.objects[i].distractor) continue;  // only instances are scored
        SyntheticScene alone;
        alone.shapes = scene.shapes;
        alone.objects = {scene.objects[i]};
        alone.plane_half_size = Eigen::Vector2f::Zero();
        alone.camera = scene.camera;
        const std::size_t unhidden = scan_scene(alone, wide, seed).visible_points[0];
        // Nothing of it would be seen even alone (beyond the range, edge on): none of it is visible.
        fractions[i] = unhidden > 0 ? std::min(1.0f, float(scan.visible_points[i]) / float(unhidden)) : 0.0f;
    }
    return fractions;
}

SyntheticDataset scan_synthetic_scene(SyntheticScene scene, const SensorParams& sensor, std::uint32_t seed)
{
    check_sensor(sensor);
    detail::check_camera_reach(scene, sensor);
    SyntheticDataset dataset;
    dataset.seed = seed;
    dataset.sensor = sensor;
    dataset.scene = std::move(scene);
    dataset.scan = scan_scene(dataset.scene, sensor, seed);
    dataset.fovea = fovea_per_instance(dataset.scene);
    return dataset;
}

SyntheticDataset make_synthetic_dataset(std::vector<SceneShape> shapes, const ComposeParams& compose,
                                        const SensorParams& sensor, float model_spacing, const FeatureParams& features,
                                        bool describe_model)
{
    check_sensor(sensor);
    check_model_spacing(model_spacing);
    SyntheticDataset dataset = scan_synthetic_scene(compose_scene(std::move(shapes), compose), sensor, compose.seed);
    dataset.models = detail::model_clouds(dataset.scene, model_spacing);
    if (describe_model) dataset.model = detail::describe_object(dataset.scene, dataset.models[0], features, sensor);
    return dataset;
}

void check_model_spacing(float spacing)
{
    if (!(spacing >= 0.0005f && spacing <= 0.01f))
        throw Error("model spacing", "must lie in 0.0005..0.01 m (coarser models leave too few points to verify)");
}

void prepare_output_directory(const std::filesystem::path& directory)
{
    std::error_code error;
    std::filesystem::create_directories(directory, error);
    if (error || !std::filesystem::is_directory(directory, error))
        throw Error(directory.string(), "cannot create the directory" + (error ? ": " + error.message() : std::string()));
}

GroundTruth ground_truth_of(const SyntheticDataset& dataset)
{
    GroundTruth truth;
    truth.model = detail::model_cloud_files(dataset.scene).at(0);
    const Pose world_to_camera = dataset.scene.camera.inverse();
    for (std::size_t i = 0; i < dataset.scene.objects.size(); ++i) {
        const SceneObject& object = dataset.scene.objects[i];
        if (object.distractor) continue;
        GroundTruthInstance instance;
        instance.transform = world_to_camera * object.pose;
        instance.object = dataset.scene.shapes[object.shape].name;
        instance.visible_points = long(dataset.scan.visible_points[i]);
        if (i < dataset.visible_fraction.size()) instance.visible_fraction = dataset.visible_fraction[i];
        const SceneShape& shape = dataset.scene.shapes[object.shape];
        instance.symmetry_order = shape.symmetry_order;
        if (shape.symmetry_flip) {
            float low = std::numeric_limits<float>::infinity(), high = -low;
            for (const Eigen::Vector3f& p : outline(shape)) {
                low = std::min(low, p.z());
                high = std::max(high, p.z());
            }
            instance.symmetry_flip = true;
            instance.flip_axis = Eigen::Vector3f::UnitX();
            instance.flip_point = Eigen::Vector3f(0, 0, 0.5f * (low + high));
        }
        truth.instances.push_back(instance);
    }
    return truth;
}

void write_synthetic_models(const std::filesystem::path& directory, const SyntheticDataset& dataset)
{
    const SyntheticScene& scene = dataset.scene;
    if (dataset.models.size() < scene.shapes.size())
        throw Error(directory.string(), "the dataset has " + std::to_string(dataset.models.size()) +
                                            " model clouds for " + std::to_string(scene.shapes.size()) + " shapes");
    prepare_output_directory(directory);
    const std::vector<std::string> model_files = detail::model_cloud_files(scene);
    // All or none, as the scene's files below.
    StagedFiles files;
    for (std::size_t s = 0; s < scene.shapes.size(); ++s) {
        const std::filesystem::path path = directory / model_files[s];
        files.stage(path, cloud_file_bytes(path, dataset.models[s]));
    }
    if (dataset.model.features.size() > 0)
        files.stage(directory / detail::model_cache_file(scene), model_cache_bytes(dataset.model));
    files.commit();
}

void write_synthetic_dataset(const std::filesystem::path& directory, const SyntheticDataset& dataset)
{
    write_synthetic_models(directory, dataset);
    write_synthetic_scene_files(directory, dataset);
}

void write_synthetic_scene_files(const std::filesystem::path& directory, const SyntheticDataset& dataset,
                                 const std::filesystem::path& model_directory)
{
    prepare_output_directory(directory);

    const SyntheticScene& scene = dataset.scene;
    const Scan& scan = dataset.scan;
    std::vector<std::string> model_files = detail::model_cloud_files(scene);
    for (std::string& file : model_files) file = (model_directory / file).generic_string();
    // The scene's files are staged and renamed together at the end: a failure half-way (a full
    // disk, a name taken by a directory) leaves an earlier scene's files as they were, not a mix.
    StagedFiles files;
    files.stage(directory / "scene.pcd", cloud_file_bytes(directory / "scene.pcd", scan.cloud, {CloudEncoding::binary, true}));
    files.stage(directory / "labels.png", png_gray16_file_bytes(scan.cloud.width, scan.cloud.height, scan.labels,
                                                                (directory / "labels.png").string()));

    const Pose world_to_camera = scene.camera.inverse();
    nlohmann::ordered_json truth_instances = nlohmann::ordered_json::array();
    for (const GroundTruthInstance& truth : ground_truth_of(dataset).instances) {
        nlohmann::ordered_json instance = {{"transform", pose_json(truth.transform)},
                                           {"object", truth.object},
                                           {"visible_points", truth.visible_points}};
        if (truth.visible_fraction >= 0) instance["visible_fraction"] = shortest_double(truth.visible_fraction);
        if (truth.symmetry_order != 1 || truth.symmetry_flip) {
            instance["symmetry"] = {{"axis", {0, 0, 1}}, {"order", truth.symmetry_order}};
            if (truth.symmetry_flip)
                instance["symmetry"]["flip"] = {
                    {"axis", {truth.flip_axis.x(), truth.flip_axis.y(), truth.flip_axis.z()}},
                    {"point", {truth.flip_point.x(), truth.flip_point.y(), shortest_double(truth.flip_point.z())}}};
        }
        truth_instances.push_back(instance);
    }
    nlohmann::ordered_json objects = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        const SceneObject& object = scene.objects[i];
        const Pose transform = world_to_camera * object.pose;
        objects.push_back({{"label", label_first_object + i},
                           {"shape", scene.shapes[object.shape].name},
                           {"model", model_files[object.shape]},
                           {"distractor", object.distractor},
                           {"visible_points", scan.visible_points[i]},
                           {"transform", pose_json(transform)},
                           {"pose_in_world", pose_json(object.pose)}});
    }
    files.stage(directory / "scene.gt.json",
                detail::json_file_text({{"model", model_files[0]}, {"instances", truth_instances}}));

    const SensorParams& sensor = dataset.sensor;
    const Camera camera = scan.camera;
    nlohmann::ordered_json manifest = {
        {"seed", dataset.seed},
        {"scene", "scene.pcd"},
        {"labels", {{"file", "labels.png"}, {"none", label_none}, {"plane", label_plane}, {"first_object", label_first_object}}},
        {"sensor",
         {{"width", sensor.width}, {"height", sensor.height}, {"fx", camera.fx}, {"fy", camera.fy}, {"cx", camera.cx},
          {"cy", camera.cy}, {"noise_at_1m", sensor.noise_at_1m}, {"baseline", sensor.baseline},
          {"disparity_subpixel", sensor.disparity_subpixel}, {"max_incidence_deg", sensor.max_incidence_deg},
          {"min_range", sensor.min_range}, {"max_range", sensor.max_range}}},
        {"camera_in_world", pose_json(scene.camera)},
        {"plane_half_size", {scene.plane_half_size.x(), scene.plane_half_size.y()}},
        {"points", scan.cloud.size()},
        {"objects", objects}};
    if (dataset.frame)
        manifest["frame"] = {{"index", dataset.frame->index},
                             {"noise_seed", dataset.frame->noise_seed},
                             {"heading_deg", dataset.frame->heading_deg}};
    files.stage(directory / "scene.json", detail::json_file_text(manifest));
    // A scene without instances has no fovea to place, and a config needs one structure.
    if (!dataset.fovea.structures.empty()) {
        files.stage(directory / "fovea.json", to_json(dataset.fovea) + '\n');
        files.stage(directory / "fovea_all.json", to_json(fovea_covering_all(scene)) + '\n');
    }
    files.commit();
}

}  // namespace mfpc
