#pragma once

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
std::span<const std::string_view> sensor_preset_names();
/// @throws mfpc::Error naming the preset when it is none of sensor_preset_names().
SensorParams sensor_preset(std::string_view name);

/// @brief What write_synthetic_set generates.
struct SyntheticSetParams {
    std::vector<std::string> presets = {"kinect"};  ///< sensor presets; each is a group of the set
    std::uint32_t scenes = 40;       ///< scenes per preset
    std::uint32_t first_seed = 1;    ///< scene k of every preset has seed first_seed + k
    std::uint32_t objects = 2;       ///< instances of the scene's object to recognise
    std::uint32_t distractors = 3;   ///< other built-in objects among them
    /// The objects to recognise, scene k taking shapes[k % size]; every built-in by default.
    std::vector<std::string> shapes;
    /// Camera distance from the objects' centre, metres (scaled up with a crowded table). With the
    /// objects spread over it, they stand from about 0.4 m to 1.5 m from the sensor (measured over
    /// 40 scenes: 0.42 to 1.59 m, 95% below 1.48 m).
    float camera_distance_min = 0.4f;
    float camera_distance_max = 1.1f;
    float model_spacing = 0.002f;
    FeatureParams features = RecognitionParams{}.model;  ///< how the models are described
};

/// @brief Called after each scene written: scenes done, scenes in all.
using SyntheticSetProgress = std::function<void(std::size_t done, std::size_t total)>;

/// @brief Writes a synthetic benchmark set into `directory`: `models/<preset>_<shape>.mfpcm`, each
/// shape described once per preset from views 1 m away (so scenes at other distances test the
/// description's density invariance); one directory `<preset>_<NNN>` per scene as `mfpc synth`
/// writes it, its ground truth with each instance's visible fraction; and `dataset.json`, the
/// manifest for `mfpc evaluate`. The same parameters give the same files on any thread count.
/// @throws mfpc::Error for an unknown preset or shape, no scenes, or a directory that cannot be made.
void write_synthetic_set(const std::filesystem::path& directory, const SyntheticSetParams& params,
                         const SyntheticSetProgress& progress = {});

}  // namespace mfpc
