#pragma once

// Private to tools/simulation (its src/ is not installed): what the writers of a synthetic scene
// (`mfpc synth`), a benchmark set (`mfpc synth-set`) and a sequence of frames (`mfpc synth
// --sequence`) share: file names of the models, the checks and pieces of make_synthetic_dataset,
// JSON files and the dataset manifest `mfpc evaluate` reads.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mfpc/simulation/synthetic_scene.hpp"

namespace mfpc::detail {

// A shape's name made a file name: a safe alphabet, and off the names of a dataset's own files (a
// mesh named scene.ply must not have its model overwritten by the scan).
std::string file_safe(const std::string& name);

// Per shape of the scene, the file name of its model cloud: <shape>.pcd, or <shape>_<s>.pcd for
// a second shape of one name (a file named like a built-in).
std::vector<std::string> model_cloud_files(const SyntheticScene& scene);
// The file name of the model cache of the object to recognise (shapes[0]): <shape>.mfpcm.
std::string model_cache_file(const SyntheticScene& scene);

// Throws when the camera stands farther from every object than the sensor's max_range (a crowded
// table moves the camera back; past the range the scan would be empty).
void check_camera_reach(const SyntheticScene& scene, const SensorParams& sensor);

// Per shape of the scene, its model cloud: a mesh's surface sampled at `model_spacing` (a fixed
// sampling seed, so a shape's model is the same file in every scene), a cloud shape's discs.
std::vector<PointCloud> model_clouds(const SyntheticScene& scene, float model_spacing);
// The object to recognise (shapes[0]) described from views with the sensor's noise model
// (view_model_params); its source is its model cloud's file name.
Model describe_object(const SyntheticScene& scene, const PointCloud& surface, const FeatureParams& features,
                      const SensorParams& sensor);

// Writes `json` indented, atomically. File names in the document may not be UTF-8: their bad bytes
// become U+FFFD, not an exception.
void write_json_file(const std::filesystem::path& path, const nlohmann::ordered_json& json);
// The text write_json_file writes.
std::string json_file_text(const nlohmann::ordered_json& json);

// One scene of a dataset manifest, for a scene write_synthetic_scene_files wrote into the directory
// `name` beside the manifest: its cloud, ground truth and (when it has one) fovea config.
nlohmann::ordered_json manifest_scene(const std::string& name, const std::string& model, bool has_fovea,
                                      const std::string& group);
// Writes `directory`/dataset.json, the manifest `mfpc evaluate --dataset` reads: the set is named
// after the directory.
void write_manifest(const std::filesystem::path& directory, const nlohmann::ordered_json& models,
                    const nlohmann::ordered_json& scenes);

}  // namespace mfpc::detail
