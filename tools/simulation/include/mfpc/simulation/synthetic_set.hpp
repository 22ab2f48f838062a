#pragma once

/// @file
/// @brief Synthetic benchmark sets: the sensor presets and writing a whole set with its manifest.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mfpc/recognition/params.hpp"
#include "mfpc/simulation/virtual_scanner.hpp"

namespace mfpc {

/// @brief The sensor presets of the synthetic benchmark sets: "kinect" (640x480, fx 525,
/// structured light: 1.5 mm at 1 m growing with z^2, disparity in 1/8 pixel), "stereo" (640x480,
/// fx 960: finer pixels and a narrower view, 2 mm at 1 m, 12 cm baseline, 1/16 pixel) and
/// "hd720" (1280x720, fx 910, an active-stereo camera: 1 mm at 1 m, 5 cm baseline, 1/16 pixel).
/// @return "kinect", "stereo" and "hd720".
std::span<const std::string_view> sensor_preset_names();
/// @brief The sensor of a preset (see sensor_preset_names).
/// @param name The preset's name.
/// @return Its sensor.
/// @throws mfpc::Error naming the preset when it is none of sensor_preset_names().
SensorParams sensor_preset(std::string_view name);

/// @brief What write_synthetic_set generates.
struct SyntheticSetParams {
    std::vector<std::string> presets = {"kinect"};  ///< Sensor presets; each is a group of the set.
    std::uint32_t scenes = 40;       ///< Scenes per preset.
    std::uint32_t first_seed = 1;    ///< Scene k of every preset has seed first_seed + k.
    std::uint32_t objects = 2;       ///< Instances of the scene's object to recognise.
    std::uint32_t distractors = 3;   ///< Other built-in objects among them.
    /// The objects to recognise, scene k taking shapes[k % size]; every built-in by default.
    std::vector<std::string> shapes;
    /// Camera distance from the objects' centre, metres (scaled up with a crowded table). With the
    /// objects spread over it, they stand from about 0.4 m to 1.5 m from the sensor (measured over
    /// 40 scenes: 0.42 to 1.59 m, 95% below 1.48 m).
    float camera_distance_min = 0.4f;
    float camera_distance_max = 1.1f;  ///< ... up to this.
    float model_spacing = 0.002f;      ///< Spacing of the model clouds (metres; see check_model_spacing).
    FeatureParams features = RecognitionParams{}.model;  ///< How the models are described.
};

/// @brief Called after each model and each scene written: steps done, steps in all (the presets
/// times the shapes and scenes of each).
using SyntheticSetProgress = std::function<void(std::size_t done, std::size_t total)>;

/// @brief Writes a synthetic benchmark set into `directory`: `models/<preset>_<shape>.mfpcm`, each
/// shape described once per preset from views 1 m away (so scenes at other distances test the
/// description's density invariance); one directory `<preset>_<NNN>` per scene as `mfpc synth`
/// writes it, its ground truth with each instance's visible fraction; and `dataset.json`, the
/// manifest for `mfpc evaluate`. The same parameters give the same files on any thread count.
/// @param directory The set's directory; created if missing. Its name is the set's.
/// @param params What to generate.
/// @param progress When given, called after each model and each scene written.
/// @throws mfpc::Error for an unknown preset or shape, a preset or shape named twice, no presets,
/// no scenes, a model spacing check_model_spacing refuses, a directory that cannot be made, or as
/// generating and writing each scene (make_synthetic_dataset, write_synthetic_dataset).
void write_synthetic_set(const std::filesystem::path& directory, const SyntheticSetParams& params,
                         const SyntheticSetProgress& progress = {});

}  // namespace mfpc
