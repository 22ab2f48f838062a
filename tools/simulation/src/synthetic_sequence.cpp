#include "mfpc/simulation/synthetic_sequence.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/error.hpp"
#include "synthetic_files.hpp"

namespace mfpc {

void check_sequence_params(const SequenceParams& params)
{
    if (params.frames < 2 || params.frames > 10000)
        throw Error("frames", "must lie in 2..10000, not " + std::to_string(params.frames));
    if (!(std::isfinite(params.arc_deg) && params.arc_deg > 0 && params.arc_deg <= 360))
        throw Error("arc_deg", "must be finite and in (0, 360] degrees, not " + format_number(params.arc_deg));
}

double sequence_heading_step_deg(const SequenceParams& params)
{
    return double(params.arc_deg) / (double(params.frames) - 1.0);
}

Pose sequence_camera(const SyntheticScene& scene, const SequenceParams& params, std::uint32_t frame)
{
    check_sequence_params(params);
    if (frame >= params.frames)
        throw Error("frame", std::to_string(frame) + " is past the sequence's last frame, " +
                                 std::to_string(params.frames - 1));
    if (frame == 0) return scene.camera;
    // The turn about the vertical through the centre, in double so that a long sequence's last
    // frames stand where they should; the camera's frame turns with it (x stays level).
    const double turn = double(frame) * sequence_heading_step_deg(params) * std::numbers::pi / 180.0;
    const Eigen::Matrix3d rotation = Eigen::AngleAxisd(turn, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d centre = objects_centre(scene).cast<double>();
    Pose camera = Pose::Identity();
    camera.linear() = (rotation * scene.camera.linear().cast<double>()).cast<float>();
    camera.translation() = (centre + rotation * (scene.camera.translation().cast<double>() - centre)).cast<float>();
    return camera;
}

std::uint32_t sequence_frame_seed(std::uint32_t seed, std::uint32_t frame)
{
    // An odd multiplier: distinct frames get distinct seeds (modulo 2^32), far apart.
    return seed + frame * 0x9E3779B9u;
}

SyntheticDataset make_sequence_frame(const SyntheticScene& scene, const SensorParams& sensor, std::uint32_t seed,
                                     const SequenceParams& params, std::uint32_t frame)
{
    SyntheticScene moved = scene;
    moved.camera = sequence_camera(scene, params, frame);
    const std::uint32_t noise_seed = sequence_frame_seed(seed, frame);
    SyntheticDataset dataset = scan_synthetic_scene(std::move(moved), sensor, noise_seed);
    dataset.seed = seed;
    dataset.frame = SequenceFrame{frame, noise_seed, double(frame) * sequence_heading_step_deg(params)};
    dataset.visible_fraction = visible_fraction_of(dataset.scene, dataset.scan, sensor, noise_seed);
    return dataset;
}

std::string sequence_frame_directory(std::uint32_t frame, std::uint32_t frames)
{
    const std::size_t digits = std::to_string(frames > 0 ? frames - 1 : 0).size();
    std::string index = std::to_string(frame);
    if (index.size() < std::max<std::size_t>(3, digits)) index.insert(0, std::max<std::size_t>(3, digits) - index.size(), '0');
    return "frame_" + index;
}

void write_synthetic_sequence(const std::filesystem::path& directory, std::vector<SceneShape> shapes,
                              const ComposeParams& compose, const SensorParams& sensor,
                              const SequenceParams& sequence, float model_spacing, const FeatureParams& features,
                              const SequenceProgress& progress)
{
    check_sequence_params(sequence);
    check_sensor(sensor);
    check_model_spacing(model_spacing);
    prepare_output_directory(directory);

    // The objects stand still: composed once, their models sampled and described once.
    SyntheticDataset models;
    models.scene = compose_scene(std::move(shapes), compose);
    // Every frame's camera must reach the objects, before the long work starts.
    for (std::uint32_t k = 0; k < sequence.frames; ++k) {
        SyntheticScene placement;
        placement.objects = models.scene.objects;
        placement.camera = sequence_camera(models.scene, sequence, k);
        detail::check_camera_reach(placement, sensor);
    }
    models.models = detail::model_clouds(models.scene, model_spacing);
    models.model = detail::describe_object(models.scene, models.models[0], features, sensor);
    write_synthetic_models(directory, models);
    const std::size_t total = std::size_t(sequence.frames) + 1;
    std::size_t done = 0;
    if (progress) progress(++done, total);

    const std::string cache = detail::model_cache_file(models.scene);
    const std::string model = std::filesystem::path(cache).stem().string();
    nlohmann::ordered_json model_entries = nlohmann::ordered_json::array();
    model_entries.push_back({{"name", model}, {"file", cache}});
    nlohmann::ordered_json scenes = nlohmann::ordered_json::array();
    std::string frame_list;
    for (std::uint32_t k = 0; k < sequence.frames; ++k) {
        const SyntheticDataset frame = make_sequence_frame(models.scene, sensor, compose.seed, sequence, k);
        const std::string name = sequence_frame_directory(k, sequence.frames);
        write_synthetic_scene_files(directory / name, frame, "..");
        scenes.push_back(detail::manifest_scene(name, model, !frame.fovea.structures.empty(), "sequence"));
        frame_list += name + "/scene.pcd\n";
        if (progress) progress(++done, total);
    }
    detail::write_manifest(directory, model_entries, scenes);
    write_file_atomically(directory / "frames.txt", [&](std::ofstream& out) { out << frame_list; });
}

}  // namespace mfpc
