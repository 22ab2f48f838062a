#pragma once

/// @file
/// @brief Synthetic scenes: shapes from built-in objects, meshes and clouds, the scene composer,
/// foveae around the instances, and the dataset `mfpc synth` writes.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/simulation/view_model.hpp"
#include "mfpc/simulation/virtual_scanner.hpp"

namespace mfpc {

/// @brief A built-in object as a shape for the scanner: its mesh and its symmetry order.
/// @param name A built-in object's name (builtin_object_names).
/// @return The shape, named `name`.
/// @throws mfpc::Error naming the object for an unknown name.
SceneShape make_builtin_shape(const std::string& name);
/// @brief The built-in objects as shapes for compose_scene: `first` (a built-in name) first, as the
/// object to recognise, then the others, as distractors.
/// @param first The built-in object to recognise.
/// @return Every built-in object's shape, `first` first.
/// @throws mfpc::Error naming the object when `first` is not built in.
std::vector<SceneShape> builtin_scene_shapes(const std::string& first = "carton");
/// @brief A point-cloud model as a shape: discs with normals.
///
/// A cloud model is turned into its own frame: `up` (in the cloud's frame; Kinect clouds have y
/// down, so the default is -y) becomes z, its footprint is centred on the z axis and its lowest
/// point lies on z = 0. Normals are estimated (k = 10, towards the cloud's sensor origin) when the
/// file has none, and the disc radius is the median nearest-neighbour distance, so neighbouring
/// discs overlap and the surface has no holes. Points without a defined normal are left out.
/// @param cloud The cloud model.
/// @param name The shape's name, also named by errors.
/// @param up The cloud's up direction, in its own frame.
/// @return The shape.
/// @throws mfpc::Error naming `name` for a cloud check_cloud refuses, fewer than 3 points, an up
/// direction that is zero or not finite, points that all lie at one spot, or fewer than 3 points
/// with a defined normal.
SceneShape make_cloud_shape(const PointCloud& cloud, const std::string& name,
                            const Eigen::Vector3f& up = Eigen::Vector3f(0, -1, 0));
/// @brief A shape for the scanner from a built-in object name, a mesh file (.ply, .obj) or a
/// point-cloud model (.pcd, .ply with no faces is read as a mesh error: use .pcd for clouds).
///
/// A file's shape is named after its stem, made safe for a file name.
/// @param name_or_path A built-in object's name, else a file.
/// @param cloud_up The up direction of a cloud model, as make_cloud_shape takes it.
/// @return The shape.
/// @throws mfpc::Error for a name that is neither built in nor a .ply, .obj or .pcd file, or as
/// read_mesh, read_cloud and make_cloud_shape.
SceneShape load_shape(const std::string& name_or_path, const Eigen::Vector3f& cloud_up = Eigen::Vector3f(0, -1, 0));

/// @brief The parameters of the scene composer.
///
/// The scene composer: `objects` instances of shapes[0] and `distractors` objects drawn from
/// shapes[1..], standing upright at seeded random positions and headings on a table top, never
/// interpenetrating (their footprint circles keep a gap); the placement area grows with the
/// objects' footprints so any count fits. The camera looks at the objects' centre from a seeded
/// random heading, elevation and distance, so objects in front partly hide those behind.
struct ComposeParams {
    std::uint32_t seed = 1;          ///< Of the positions, headings and the camera.
    std::uint32_t objects = 3;       ///< Instances of shapes[0].
    std::uint32_t distractors = 3;   ///< Objects drawn from shapes[1..].
    float placement_half_x = 0.25f;  ///< Metres: the table area objects stand in (grown when crowded), half its x extent ...
    float placement_half_y = 0.18f;  ///< ... and half its y extent.
    float gap = 0.01f;               ///< Between footprints (metres).
    float camera_distance_min = 0.65f;  ///< Metres from the objects' centre (grown with the area when crowded) ...
    float camera_distance_max = 0.9f;   ///< ... up to this.
    float camera_elevation_min_deg = 30.0f;  ///< Above the table (degrees) ...
    float camera_elevation_max_deg = 55.0f;  ///< ... up to this.
};

/// @brief Composes a scene (see ComposeParams). The same shapes and parameters give the same scene
/// with the same standard library (the random distributions are libstdc++'s).
/// @param shapes The shape to recognise first, then the distractor shapes.
/// @param params The composer's parameters.
/// @return The scene: the shapes, the objects (instances first, then distractors), a table top
/// reaching well past them, and the camera.
/// @throws mfpc::Error for no shapes, distractors without a distractor shape, nothing to place,
/// contradictory parameters (distances, elevations, placement area or gap), or objects that cannot
/// be placed without overlap.
SyntheticScene compose_scene(std::vector<SceneShape> shapes, const ComposeParams& params);

/// @brief The point compose_scene's camera looks at: the mean of the objects' positions on the
/// table, 8 cm above it (mid-height of a typical object).
/// @param scene The scene.
/// @return The point, in the world frame; the origin 8 cm up for a scene without objects.
Eigen::Vector3f objects_centre(const SyntheticScene& scene);

/// @brief The axis-aligned box, in the camera frame, of object `index` as placed in the scene.
/// @param scene The scene.
/// @param index The object.
/// @return The box of its outline's points.
/// @throws std::out_of_range for an object or a shape the scene does not have.
Box object_box_in_camera(const SyntheticScene& scene, std::size_t index);

/// @brief One foveated structure per non-distractor object: the fovea is the object's box in the
/// camera frame grown by 1 cm, the outer box that grown by 10 cm; m = 3, d = 2 cm .. 5 mm, r = 3 cm
/// .. 1 cm (the densities and radii of the shipped milk-carton configs).
/// @param scene The scene.
/// @return The config; without structures for a scene without instances.
FoveationConfig fovea_per_instance(const SyntheticScene& scene);
/// @brief One structure whose fovea holds every instance (the paper's FCAS strategy), sized the
/// same way.
/// @param scene The scene.
/// @return The config; without structures for a scene without instances.
FoveationConfig fovea_covering_all(const SyntheticScene& scene);

/// @brief Where a scan stands in a sequence of frames (synthetic_sequence.hpp).
struct SequenceFrame {
    std::uint32_t index = 0;       ///< The frame's index, 0 the first.
    std::uint32_t noise_seed = 0;  ///< The seed of the frame's sensor noise (sequence_frame_seed).
    /// Degrees the camera's heading has turned about the objects' centre since frame 0
    /// (counter-clockwise seen from above: the camera walks to its right).
    double heading_deg = 0;
};

/// @brief A synthetic scene, its scan and what `mfpc synth` writes of it.
///
/// What `mfpc synth` writes into a directory:
///
///     scene.pcd        organized scan (binary PCD, NaN where no return), camera frame
///     scene.gt.json    ground truth in the shared format: model file, instances (transform maps the
///                      model cloud into the scene), plus each instance's object name and visible points
///     labels.png       16-bit grey label per pixel: 0 no return, 1 table, 2 + i object i of scene.json
///     scene.json       everything: seed, sensor, camera, objects (shape, distractor, poses, label, visible points),
///                      and for a frame of a sequence, "frame" (index, noise_seed, heading_deg)
///     fovea.json       one foveated structure per instance (fovea_per_instance); absent without instances
///     fovea_all.json   one structure covering every instance (fovea_covering_all); absent likewise
///     <shape>.pcd      each shape's full model cloud with normals, in its own frame (the GT's model)
///     <object>.mfpcm   the model cache of the object to recognise, described from views
///                      (prepare_view_model, default recognition parameters), for `mfpc recognize`
struct SyntheticDataset {
    SyntheticScene scene;            ///< The composed scene.
    Scan scan;                       ///< Its scan.
    FoveationConfig fovea;           ///< One structure per instance (fovea_per_instance).
    std::vector<PointCloud> models;  ///< Per shape: its full model cloud with normals, in its own frame.
    Model model;                     ///< shapes[0] described from views (empty when not described).
    /// The composer's seed, which also keys the sensor noise (but for a frame of a sequence, whose
    /// noise has a seed of its own: SequenceFrame::noise_seed).
    std::uint32_t seed = 0;
    SensorParams sensor;             ///< The sensor of the scan.
    /// Per object: the share of its surface the sensor would see with nothing in the way and no
    /// image border (visible_fraction_of); empty when not measured.
    std::vector<float> visible_fraction;
    /// For a frame of a sequence (make_sequence_frame): where it stands, written to scene.json as
    /// "frame"; empty for a scene on its own.
    std::optional<SequenceFrame> frame;
};

/// @brief Composes, scans (seed also keys the sensor noise), samples the model clouds at
/// model_spacing and, with `describe_model`, describes the object to recognise from views with
/// `features` (a set of scenes describes each shape once instead). visible_fraction is left empty.
/// @param shapes The shape to recognise first, then the distractor shapes.
/// @param compose The composer's parameters.
/// @param sensor The sensor.
/// @param model_spacing The spacing of the shapes' model clouds (sample_surface; a cloud shape's
/// discs are its model as they are).
/// @param features How the object to recognise is described.
/// @param describe_model Whether to describe it.
/// @return The dataset.
/// @throws mfpc::Error for a sensor check_sensor refuses, a model spacing check_model_spacing
/// refuses, when the objects need a camera farther than the sensor's max_range, or as
/// compose_scene, the scan, sample_surface and prepare_view_model.
SyntheticDataset make_synthetic_dataset(std::vector<SceneShape> shapes, const ComposeParams& compose,
                                        const SensorParams& sensor, float model_spacing = 0.002f,
                                        const FeatureParams& features = RecognitionParams{}.model,
                                        bool describe_model = true);

/// @brief The scan of a scene as make_synthetic_dataset takes it: checks that the camera reaches
/// the objects, scans (seed keys the sensor noise) and places one fovea per instance. The models
/// are left empty, visible_fraction too.
/// @param scene The scene.
/// @param sensor The sensor.
/// @param seed Keys the sensor noise; also the dataset's seed.
/// @return The dataset of the scan.
/// @throws mfpc::Error for a sensor check_sensor refuses, when the objects all lie beyond the
/// sensor's max_range, or as the scan.
SyntheticDataset scan_synthetic_scene(SyntheticScene scene, const SensorParams& sensor, std::uint32_t seed);

/// @brief The views a dataset's model is described from: the scene sensor's noise model at VGA,
/// 1 m away. They keep its noise, baseline, disparity quantization and incidence limit, but not its
/// resolution, focal length or range (their 1 m distance lies in the default range whatever the
/// scene's).
/// @param sensor The scene's sensor.
/// @return The views' parameters.
ViewModelParams view_model_params(const SensorParams& sensor);

/// @brief Per object of the scan: its visible points over those a scan of the object alone (no
/// other object, no table, an image twice as wide and high about the same principal point)
/// returns, at most 1: what occlusion and the image border leave of it.
/// @param scene The scene.
/// @param scan Its scan.
/// @param sensor The scan's sensor.
/// @param seed The scan's seed.
/// @return One fraction per object: -1 for distractors (not measured), 0 for an object that would
/// not be seen even alone.
/// @throws mfpc::Error as the scanner does.
std::vector<float> visible_fraction_of(const SyntheticScene& scene, const Scan& scan, const SensorParams& sensor,
                                       std::uint32_t seed);

/// @brief Writes the files above (those SyntheticDataset lists, each atomically) into `directory`,
/// created if missing; the model cache only when the dataset's model was described.
/// write_synthetic_models, then write_synthetic_scene_files.
/// @param directory The directory.
/// @param dataset The dataset.
/// @throws mfpc::Error when the directory cannot be created or a file cannot be written.
void write_synthetic_dataset(const std::filesystem::path& directory, const SyntheticDataset& dataset);
/// @brief Writes the models of a dataset (each atomically) into `directory`, created if missing:
/// `<shape>.pcd` per shape (dataset.models; a shape named like a scene file gets `_model`
/// appended, a second shape of one name `_<index>`) and, when its model was described,
/// `<object>.mfpcm`. Only dataset.scene's shapes, dataset.models and dataset.model are read.
/// @param directory The directory.
/// @param dataset The dataset.
/// @throws mfpc::Error when the directory cannot be created, a file cannot be written, or the
/// dataset has fewer model clouds than shapes.
void write_synthetic_models(const std::filesystem::path& directory, const SyntheticDataset& dataset);
/// @brief Writes the files of a dataset's scan (each atomically) into `directory`, created if
/// missing: scene.pcd, labels.png, scene.gt.json, scene.json and, with instances, fovea.json and
/// fovea_all.json; not the models (dataset.models and dataset.model are not read).
/// @param directory The directory.
/// @param dataset The dataset.
/// @param model_directory Where the models lie, relative to `directory` (".." for the frames of a
/// sequence, whose models are written once above them): the model files of scene.gt.json and
/// scene.json are named through it. Empty: beside the scene, as write_synthetic_dataset writes them.
/// @throws mfpc::Error when the directory cannot be created or a file cannot be written.
void write_synthetic_scene_files(const std::filesystem::path& directory, const SyntheticDataset& dataset,
                                 const std::filesystem::path& model_directory = {});

/// @brief Creates `directory` if missing, so a command can refuse a bad output before long work.
/// @param directory The directory.
/// @throws mfpc::Error when it cannot be created, or names a file.
void prepare_output_directory(const std::filesystem::path& directory);
/// @brief Checks a model spacing.
/// @param spacing The spacing (metres).
/// @throws mfpc::Error for a model spacing outside 0.5 mm .. 1 cm.
void check_model_spacing(float spacing);

/// @brief The ground truth of the dataset's instances (what scene.gt.json holds).
/// @param dataset The dataset.
/// @return The model file and one instance per non-distractor object, with its object name,
/// visible points, visible fraction (when measured) and symmetry.
GroundTruth ground_truth_of(const SyntheticDataset& dataset);

}  // namespace mfpc
