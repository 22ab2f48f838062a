#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/simulation/view_model.hpp"
#include "mfpc/simulation/virtual_scanner.hpp"

namespace mfpc {

// A shape for the scanner from a built-in object name, a mesh file (.ply, .obj) or a point-cloud
// model (.pcd, .ply with no faces is read as a mesh error: use .pcd for clouds).
//
// A cloud model is turned into its own frame: `up` (in the cloud's frame; Kinect clouds have y
// down, so the default is -y) becomes z, its footprint is centred on the z axis and its lowest
// point lies on z = 0. Normals are estimated (k = 10, towards the cloud's sensor origin) when the
// file has none, and the disc radius is the median nearest-neighbour distance, so neighbouring
// discs overlap and the surface has no holes.
SceneShape make_builtin_shape(const std::string& name);
// The built-in objects as shapes for compose_scene: `first` (a built-in name) first, as the object
// to recognise, then the others, as distractors.
std::vector<SceneShape> builtin_scene_shapes(const std::string& first = "carton");
SceneShape make_cloud_shape(const PointCloud& cloud, const std::string& name,
                            const Eigen::Vector3f& up = Eigen::Vector3f(0, -1, 0));
SceneShape load_shape(const std::string& name_or_path, const Eigen::Vector3f& cloud_up = Eigen::Vector3f(0, -1, 0));

// The scene composer: `objects` instances of shapes[0] and `distractors` objects drawn from
// shapes[1..], standing upright at seeded random positions and headings on a table top, never
// interpenetrating (their footprint circles keep a gap); the placement area grows with the
// objects' footprints so any count fits. The camera looks at the objects' centre from a seeded
// random heading, elevation and distance, so objects in front partly hide those behind.
struct ComposeParams {
    std::uint32_t seed = 1;
    std::uint32_t objects = 3;
    std::uint32_t distractors = 3;
    float placement_half_x = 0.25f;  // metres: the table area objects stand in (grown when crowded)
    float placement_half_y = 0.18f;
    float gap = 0.01f;               // between footprints
    float camera_distance_min = 0.65f;  // metres from the objects' centre
    float camera_distance_max = 0.9f;
    float camera_elevation_min_deg = 30.0f;  // above the table
    float camera_elevation_max_deg = 55.0f;
};

SyntheticScene compose_scene(std::vector<SceneShape> shapes, const ComposeParams& params);

// The axis-aligned box, in the camera frame, of object `index` as placed in the scene.
Box object_box_in_camera(const SyntheticScene& scene, std::size_t index);

// One foveated structure per non-distractor object: the fovea is the object's box in the camera
// frame grown by 1 cm, the outer box that grown by 10 cm; m = 3, d = 2 cm .. 5 mm, r = 3 cm .. 1 cm
// (the densities and radii of the shipped milk-carton configs).
FoveationConfig fovea_per_instance(const SyntheticScene& scene);
// One structure whose fovea holds every instance (the paper's FCAS strategy), sized the same way.
FoveationConfig fovea_covering_all(const SyntheticScene& scene);

// What `mfpc synth` writes into a directory:
//   scene.pcd        organized scan (binary PCD, NaN where no return), camera frame
//   scene.gt.json    ground truth in the shared format: model file, instances (transform maps the
//                    model cloud into the scene), plus each instance's object name and visible points
//   labels.png       16-bit grey label per pixel: 0 no return, 1 table, 2 + i object i of scene.json
//   scene.json       everything: seed, sensor, camera, objects (shape, distractor, poses, label, visible points)
//   fovea.json       one foveated structure per instance (fovea_per_instance); absent without instances
//   fovea_all.json   one structure covering every instance (fovea_covering_all); absent likewise
//   <shape>.pcd      each shape's full model cloud with normals, in its own frame (the GT's model)
//   <object>.mfpcm   the model cache of the object to recognise, described from views
//                    (prepare_view_model, default recognition parameters), for `mfpc recognize`
struct SyntheticDataset {
    SyntheticScene scene;
    Scan scan;
    FoveationConfig fovea;
    std::vector<PointCloud> models;  // per shape
    Model model;                     // shapes[0] described from views
    std::uint32_t seed = 0;
    SensorParams sensor;
    // Per object: the share of its surface the sensor would see with nothing in the way and no
    // image border (visible_fraction_of); empty when not measured.
    std::vector<float> visible_fraction;
};

// Composes, scans (seed also keys the sensor noise), samples the model clouds at model_spacing and,
// with `describe_model`, describes the object to recognise from views with `features` (a set of
// scenes describes each shape once instead). Throws mfpc::Error when the objects need a camera
// farther than the sensor's max_range.
SyntheticDataset make_synthetic_dataset(std::vector<SceneShape> shapes, const ComposeParams& compose,
                                        const SensorParams& sensor, float model_spacing = 0.002f,
                                        const FeatureParams& features = RecognitionParams{}.model,
                                        bool describe_model = true);

// The views a dataset's model is described from: the scene sensor's noise model at VGA, 1 m away.
ViewModelParams view_model_params(const SensorParams& sensor);

// Per object of the scan: its visible points over those a scan of the object alone (no other
// object, no table, an image twice as wide and high about the same principal point) returns, at
// most 1: what occlusion and the image border leave of it. -1 for distractors (not measured).
std::vector<float> visible_fraction_of(const SyntheticScene& scene, const Scan& scan, const SensorParams& sensor,
                                       std::uint32_t seed);

// Writes the files above (each atomically) into `directory`, created if missing; the model cache
// only when the dataset's model was described.
void write_synthetic_dataset(const std::filesystem::path& directory, const SyntheticDataset& dataset);

// Creates `directory` if missing; throws mfpc::Error when it cannot be, or names a file, so a
// command can refuse a bad output before long work.
void prepare_output_directory(const std::filesystem::path& directory);
// Throws mfpc::Error for a model spacing outside 0.5 mm .. 1 cm.
void check_model_spacing(float spacing);

// The ground truth of the dataset's instances (what scene.gt.json holds).
GroundTruth ground_truth_of(const SyntheticDataset& dataset);

}  // namespace mfpc
