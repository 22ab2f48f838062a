#include "mfpc/simulation/synthetic_set.hpp"

#include <array>
#include <cstdio>
#include <set>

#include <nlohmann/json.hpp>

#include "mfpc/core/error.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/simulation/mesh.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"
#include "mfpc/simulation/view_model.hpp"
#include "synthetic_files.hpp"

namespace mfpc {
namespace {

constexpr std::array<std::string_view, 3> preset_names = {"kinect", "stereo", "hd720"};

std::string scene_directory(const std::string& preset, std::uint32_t index)
{
    char name[32];
    std::snprintf(name, sizeof name, "_%03u", index);
    return preset + name;
}

}  // namespace

namespace detail {

nlohmann::ordered_json manifest_scene(const std::string& name, const std::string& model, bool has_fovea,
                                      const std::string& group)
{
    nlohmann::ordered_json scene = {{"name", name},
                                    {"model", model},
                                    {"cloud", name + "/scene.pcd"},
                                    {"ground_truth", name + "/scene.gt.json"}};
    if (has_fovea) scene["fovea"] = name + "/fovea.json";
    scene["group"] = group;
    return scene;
}

void write_manifest(const std::filesystem::path& directory, const nlohmann::ordered_json& models,
                    const nlohmann::ordered_json& scenes)
{
    // "out/set/" names the set "set" as "out/set" does, and "." names it after the working directory.
    std::filesystem::path folder = std::filesystem::absolute(directory).lexically_normal();
    if (folder.filename().empty()) folder = folder.parent_path();
    write_json_file(directory / "dataset.json", {{"name", folder.filename().string()}, {"models", models}, {"scenes", scenes}});
}

}  // namespace detail

std::span<const std::string_view> sensor_preset_names() { return preset_names; }

SensorParams sensor_preset(std::string_view name)
{
    SensorParams sensor;
    if (name == "kinect") {
        sensor.focal_length = 525.0f;
    } else if (name == "stereo") {
        sensor.focal_length = 960.0f;
        sensor.noise_at_1m = 0.002f;
        sensor.baseline = 0.12f;
        sensor.disparity_subpixel = 16;
    } else if (name == "hd720") {
        sensor.width = 1280;
        sensor.height = 720;
        sensor.focal_length = 910.0f;
        sensor.noise_at_1m = 0.001f;
        sensor.baseline = 0.05f;
        sensor.disparity_subpixel = 16;
    } else {
        throw Error("sensor preset", "'" + std::string(name) + "' is not one of kinect, stereo, hd720");
    }
    return sensor;
}

void write_synthetic_set(const std::filesystem::path& directory, const SyntheticSetParams& params,
                         const SyntheticSetProgress& progress)
{
    if (params.scenes == 0) throw Error("synthetic set", "needs at least one scene per preset");
    if (params.presets.empty()) throw Error("synthetic set", "needs at least one sensor preset");
    std::vector<std::string> shapes = params.shapes;
    if (shapes.empty())
        for (std::string_view name : builtin_object_names()) shapes.emplace_back(name);
    for (const std::string& shape : shapes)
        if (!is_builtin_object(shape)) throw Error("synthetic set", "'" + shape + "' is not a built-in object");
    if (std::set<std::string>(shapes.begin(), shapes.end()).size() != shapes.size())
        throw Error("synthetic set", "a shape is named twice");
    if (std::set<std::string>(params.presets.begin(), params.presets.end()).size() != params.presets.size())
        throw Error("synthetic set", "a preset is named twice");
    std::vector<SensorParams> sensors;
    for (const std::string& preset : params.presets) sensors.push_back(sensor_preset(preset));
    check_model_spacing(params.model_spacing);
    prepare_output_directory(directory / "models");

    nlohmann::ordered_json models = nlohmann::ordered_json::array();
    nlohmann::ordered_json scenes = nlohmann::ordered_json::array();
    const std::size_t total = params.presets.size() * (shapes.size() + params.scenes);
    std::size_t done = 0;
    for (std::size_t p = 0; p < params.presets.size(); ++p) {
        const std::string& preset = params.presets[p];
        // Each shape's model, described once per preset from its views (the preset's noise model).
        for (const std::string& shape_name : shapes) {
            const SceneShape shape = make_builtin_shape(shape_name);
            const PointCloud surface = sample_surface(shape.mesh, params.model_spacing, 1);
            Model model = prepare_view_model(shape, surface, params.features, view_model_params(sensors[p]));
            model.source = shape_name + ".pcd";
            const std::string file = "models/" + preset + "_" + shape_name + ".mfpcm";
            write_model_cache(directory / file, model);
            models.push_back({{"name", preset + "_" + shape_name}, {"file", file}});
            if (progress) progress(++done, total);
        }
        for (std::uint32_t k = 0; k < params.scenes; ++k) {
            const std::string& target = shapes[k % shapes.size()];
            ComposeParams compose;
            compose.seed = params.first_seed + k;
            compose.objects = params.objects;
            compose.distractors = params.distractors;
            compose.camera_distance_min = params.camera_distance_min;
            compose.camera_distance_max = params.camera_distance_max;
            SyntheticDataset dataset = make_synthetic_dataset(builtin_scene_shapes(target), compose, sensors[p],
                                                              params.model_spacing, params.features, false);
            dataset.visible_fraction = visible_fraction_of(dataset.scene, dataset.scan, sensors[p], compose.seed);
            const std::string name = scene_directory(preset, k);
            write_synthetic_dataset(directory / name, dataset);
            scenes.push_back(detail::manifest_scene(name, preset + "_" + target, !dataset.fovea.structures.empty(), preset));
            if (progress) progress(++done, total);
        }
    }
    detail::write_manifest(directory, models, scenes);
}

}  // namespace mfpc
