#pragma once

/// @file
/// @brief The recognition parameters (paper Table 3 and the stages after it), their JSON form and
/// their checks.

#include <filesystem>
#include <string>
#include <string_view>

namespace mfpc {

/// @brief Per-cloud feature parameters (paper Table 3; the model and the scene each have a set).
struct FeatureParams {
    /// The working resolution (metres): the cloud is described after resampling to one point per
    /// voxel of this edge (voxel_grid), so normals, keypoints and descriptors see the same surface
    /// whatever the sensor's pixel footprint and distance. 0: the cloud as sampled.
    float resolution = 0.0f;
    int normal_k = 10;             ///< k_n: neighbours of the normal PCA.
    float keypoint_radius = 0.03f;  ///< Uniform sampling radius (plain clouds; foveated ones use r_k).
    float lrf_radius = 0.015f;     ///< r_l: BOARD support (the frames Hough voting uses).
    float shot_radius = 0.02f;     ///< r_s: SHOT support.
    /// @brief Whether two sets of parameters are equal, field by field.
    /// @return True when every field matches.
    friend bool operator==(const FeatureParams&, const FeatureParams&) = default;
};

/// @brief Where the normals of a foveated scene's kept points come from.
enum class NormalsFrom {
    full,      ///< Normals of the kept points from their neighbours in the full scene.
    foveated,  ///< From their neighbours in the foveated cloud itself (paper Section 5.4).
};

/// @brief Which descriptors are queried against which.
enum class MatchDirection {
    scene_to_model,  ///< Each scene descriptor to its nearest model descriptor (the PCL tutorial).
    model_to_scene,  ///< Each model descriptor to its k nearest scene descriptors (paper Algorithm 4):
                     ///< lets one model keypoint match several instances.
};

/// @brief How the nearest descriptors are found.
///
/// scan and kdtree (FLANN's) are exact and find the same neighbours but for ties (the scan keeps
/// the lower index); scan is the faster in 352 dimensions, where a kd-tree visits nearly every
/// leaf. randomized: FLANN's randomized kd-trees, approximate and not reproducible: FLANN 1.9
/// shuffles their input with std::random_device, which no seed reaches.
enum class MatchSearch { scan, kdtree, randomized };

/// @brief How correspondences are grouped into instances: `hough`, Hough 3D voting (Tombari and
/// Di Stefano 2010), or `gc`, geometric consistency clustering.
enum class Grouping { hough, gc };

/// @brief Descriptor matching: which correspondences match_descriptors keeps.
struct MatchParams {
    MatchDirection direction = MatchDirection::model_to_scene;  ///< Which descriptors are queried.
    int k = 10;                     ///< Neighbours per query in model_to_scene.
    float threshold = 0.25f;        ///< d_max^2: squared descriptor distance accepted.
    MatchSearch search = MatchSearch::scan;  ///< How the nearest descriptors are found.
    int trees = 4;                  ///< Randomized kd-trees (approximate).
    int checks = 256;               ///< Leaves visited per query (approximate).
};

/// @brief Grouping of correspondences into instances, and each instance's pose fit.
struct GroupingParams {
    Grouping method = Grouping::hough;  ///< Hough 3D or geometric consistency.
    float hough_bin = 0.01f;        ///< L_h: Hough bin size (metres).
    float hough_threshold = 3.0f;   ///< V_h: minimum interpolated votes of a maximum.
    float gc_size = 0.01f;          ///< GC: consensus distance (metres).
    int gc_threshold = 5;           ///< GC: minimum cluster size.
    float ransac_distance = 0.01f;  ///< Inlier distance of the per-instance pose fit (metres).
    int ransac_iterations = 500;    ///< RANSAC draws of the per-instance pose fit.
    /// Hough: poses fitted per maximum (the modes of its cluster, see hough_grouping); 1: one, as
    /// PCL. Two: a nearly symmetric object's cluster often holds its true pose second.
    int ransac_modes = 2;
    float mode_inlier_ratio = 0.5f;  ///< A further mode needs this fraction of the first one's inliers.
    float mode_min_angle = 20.0f;    ///< A further mode is turned at least this far from the others (degrees).
};

/// @brief Refinement of each instance's pose by ICP onto the scene.
struct RefineParams {
    bool enabled = true;            ///< ICP of each instance onto the scene.
    int iterations = 20;            ///< ICP iterations.
    float max_distance = 0.01f;     ///< Pairs farther than this are ignored (metres).
    float model_voxel = 0.008f;     ///< The model is thinned to one point per voxel first (0: not).
    friend bool operator==(const RefineParams&, const RefineParams&) = default;
};

/// @brief Verification of the instances against the scene, and the merging of duplicates (see
/// refine_and_verify).
struct VerifyParams {
    bool enabled = true;                 ///< Whether the limits below apply.
    float inlier_distance = 0.005f;      ///< A model point fits when a scene point is this close.
    float min_inlier_fraction = 0.4f;    ///< Of the model points the sensor could see (facing it, not hidden).
    /// Inliers over the model points facing the sensor that the model itself does not hide (see
    /// model_points_in_view), whether or not the scene hides them: how much of that side the scene
    /// explains.
    float min_coverage = 0.6f;
    /// A model point faces the sensor when its surface is turned less than 75 degrees from the ray
    /// (this is cos 75°): a depth sensor gets little or no return from a more oblique surface (the
    /// synthetic scanner: none beyond 80°). Where no return came back, a carton with one side nearly
    /// edge on had over 40% of its facing points unmatched at its true pose and was refused for
    /// coverage. On 40 synthetic scenes 75° and 80° find the same cartons; 70° finds 2 of 160 fewer.
    float min_facing_cos = 0.2588f;
    /// Before ICP, a hypothesis whose facing points have a scene point within the ICP distance for
    /// less than this fraction of min_coverage is dropped: most Hough maxima in clutter are such,
    /// and true ones start within a centimetre.
    float prefilter_coverage = 0.75f;
    /// The fitting model points must be about as far from flat as the whole side of the model turned
    /// to the sensor: their thickness (spread off their best plane) over that side's. A model face
    /// laid flush on a table fits it perfectly while the rest of the model, under the table, is
    /// hidden, so neither fitness nor free space refutes it; nor does a small object's face laid on
    /// the side of a larger curved one (a bottle or a carton on a jug: 0.55-0.71 on the synthetic
    /// set, once ICP pairs only the points the sensor sees). True instances keep most of their
    /// side's depth: of the 160 found on the synthetic set, one at 0.63 and the rest 0.87 or more;
    /// the shared scenes' cartons 0.99-1.0. A flat side (under 2 mm) passes.
    float min_thickness_ratio = 0.75f;
    float flat_side = 0.002f;            ///< A facing side thinner than this (metres) is flat and passes.
    /// Rim probes 1.5 cm beyond the edges of the fitting part of the model: the fraction where the
    /// scene's surface goes on (of those where it goes on or the sensor sees past them). A pose
    /// slid along the object's face, or turned on it, leaves part of the object unexplained just
    /// beyond its edges; a true pose ends where the object does. 1: off.
    float max_continuation = 0.1f;
    /// The probes lie this far (metres) from the fitting model points, in their tangent planes:
    /// beyond sensor noise and the thinned model's spacing (a curved surface strays only r^2 / 2R
    /// from its tangent plane: 3 mm on a bottle of 7 cm). A pose slid along a face by less than
    /// rim_distance - inlier_distance is not seen by them.
    float rim_distance = 0.015f;
    /// From this many settled probes on, their share is judged as measured; fewer (a bottle's only
    /// rims are its cap and base, a few probes seen from most sides) are judged by the lower end of
    /// the share's 95% Wilson interval: 11 of 19 refutes (0.36), 1 of 5 does not (0.04).
    int min_rim_probes = 20;
    float free_space_margin = 0.01f;     ///< A model point this far in front of the observed surface ...
    float max_free_space_fraction = 0.1f;  ///< ... on this fraction of points rejects the instance.
    /// An accepted instance explaining at least this fraction of its visible points is settled: no
    /// other pose of the object fits much better (the shared scenes' cartons: 1.0), and hypotheses
    /// overlapping it are not verified. Poses slid along a flat face still explain most of it (a box
    /// slid 12 mm along its 10 cm side: 0.96), hence a bar this high.
    float settled_fitness = 0.99f;
    /// A nearly symmetric object (a mug told apart by its handle, a square carton by its gable, a
    /// box by its proportions) is often posed a turn away from its truth, on the body the two
    /// poses share. An instance that passes, or that only its rim or free space refutes, is then
    /// refined and tested again from its confusable turns (see turn_overlap) and keeps the pose the
    /// scene supports better where the poses differ (ties: the one whose seen points explain the
    /// most depth pixels); one that passed but is not settled is also
    /// tried from quarter and half turns about the model's principal axes, and keeps the pose with
    /// the most model points fitting the scene (see refine_and_verify).
    bool try_turns = true;
    /// A turn of the model about one of its axes is confusable (see try_turns) when it puts at least
    /// this fraction of the model's points within inlier_distance of the model, and not 98% of them
    /// (a symmetry, such as a bottle's about its axis, gives the same pose): on the synthetic set's
    /// objects, 0.91 for a mug about its axis (all but its handle) and a square carton by a quarter
    /// turn (all but its gable), 0.75 or less for any other turn of a carton, a box or a jug but a
    /// few degrees.
    float turn_overlap = 0.75f;
    bool merge = true;                   ///< Merge instances whose placed models overlap: ...
    float merge_distance = 0.01f;        ///< ... points closer than this (metres) overlap, ...
    float merge_overlap = 0.2f;          ///< ... and this fraction of overlapping points merges.
    friend bool operator==(const VerifyParams&, const VerifyParams&) = default;
};

/// @brief All the parameters of recognize().
///
/// The built-in defaults (README, "Recognition parameters", where the measurements are). Both
/// clouds are described at one working resolution, 5 mm: coarser than a depth sensor's pixel
/// footprint over its working range, so what is described does not depend on the sensor or the
/// distance. Every support is then metric: normals from 30 resampled points (a disc of about
/// 3 voxels' radius, wide enough to average the depth noise of far objects), scene keypoints 3
/// voxels apart, model keypoints 2, frames and descriptors over 4 cm (larger than the PCL
/// tutorial's 0.015 / 0.02, so they survive sensor noise).
struct RecognitionParams {
    FeatureParams scene{0.005f, 30, 0.015f, 0.04f, 0.04f};  ///< How the scene is described.
    /// How a model cloud is described: what prepare_model and load_model read (the params file's
    /// "model" block). recognize() takes a described Model and uses the parameters it carries
    /// (Model::params), never this; reports show the model's own.
    FeatureParams model{0.005f, 30, 0.01f, 0.04f, 0.04f};
    /// A foveated scene is described at its levels' densities, as a plain one at the resolution: its normals
    /// come from the foveated cloud (on the synthetic sets: 164 of 215 visible instances and 5 false,
    /// against 158 and 8 from the full scene's raw points).
    NormalsFrom normals_from = NormalsFrom::foveated;
    MatchParams match;        ///< Descriptor matching.
    GroupingParams grouping;  ///< Grouping and the pose fit.
    RefineParams refine;      ///< ICP refinement.
    VerifyParams verify;      ///< Verification and merging.
};

/// @brief Parses parameters JSON (every key optional, defaults above). Layout and key names:
/// README, "Recognition parameters". The values are then checked (check_recognition_params).
/// @param json_text The JSON text.
/// @param source Names the text in errors (usually the file name).
/// @return The parameters.
/// @throws mfpc::Error naming "source: key" for invalid JSON (or a duplicate key), an unknown key,
/// a wrong type, a number that is not finite or an integer out of range, the old key match_exact
/// (saying what to write instead), or any value check_recognition_params refuses.
RecognitionParams parse_recognition_params(std::string_view json_text, const std::string& source);
/// @brief Reads a parameters file, as parse_recognition_params with the path as its source.
/// @param path The JSON file.
/// @return The parameters.
/// @throws mfpc::Error naming the path when the file cannot be read (missing, a directory, not a
/// regular file, unreadable), or as parse_recognition_params.
RecognitionParams read_recognition_params(const std::filesystem::path& path);
/// @brief The parameters as JSON, every key written, in the layout parse_recognition_params reads.
/// @param params The parameters.
/// @return Indented JSON text with a final newline.
std::string to_json(const RecognitionParams& params);
/// @brief The "scene" / "model" block alone, as JSON.
/// @param params The feature parameters.
/// @return Indented JSON text with a final newline.
std::string to_json(const FeatureParams& params);
/// @brief Checks every parameter's range.
/// @param params The parameters.
/// @param source Names the parameters in errors (usually their file).
/// @throws mfpc::Error naming "source: key" for the first value out of range (a radius, distance
/// or bin that is not positive and finite, a fraction outside [0, 1], a count outside its range).
void check_recognition_params(const RecognitionParams& params, const std::string& source = "params");

/// @brief The name of a normals source, as the parameters JSON writes it.
/// @param value The normals source.
/// @return "full" or "foveated".
const char* to_string(NormalsFrom value);
/// @brief The name of a match direction, as the parameters JSON writes it.
/// @param value The direction.
/// @return "scene_to_model" or "model_to_scene".
const char* to_string(MatchDirection value);
/// @brief The name of a match search, as the parameters JSON writes it.
/// @param value The search.
/// @return "scan", "kdtree" or "randomized".
const char* to_string(MatchSearch value);
/// @brief The name of a grouping method, as the parameters JSON writes it.
/// @param value The method.
/// @return "hough" or "gc".
const char* to_string(Grouping value);

}  // namespace mfpc
