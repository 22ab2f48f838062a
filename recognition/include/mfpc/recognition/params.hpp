#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace mfpc {

// Per-cloud feature parameters (paper Table 3; the model and the scene each have a set).
struct FeatureParams {
    // The working resolution (metres): the cloud is described after resampling to one point per
    // voxel of this edge (voxel_grid), so normals, keypoints and descriptors see the same surface
    // whatever the sensor's pixel footprint and distance. 0: the cloud as sampled.
    float resolution = 0.0f;
    int normal_k = 10;             // k_n: neighbours of the normal PCA
    float keypoint_radius = 0.03f;  // uniform sampling radius (plain clouds; foveated ones use r_k)
    float lrf_radius = 0.015f;     // r_l: BOARD support (the frames Hough voting uses)
    float shot_radius = 0.02f;     // r_s: SHOT support
    friend bool operator==(const FeatureParams&, const FeatureParams&) = default;
};

enum class NormalsFrom {
    full,      // normals of the kept points from their neighbours in the full scene
    foveated,  // from their neighbours in the foveated cloud itself (paper Section 5.4)
};

enum class MatchDirection {
    scene_to_model,  // each scene descriptor to its nearest model descriptor (the PCL tutorial)
    model_to_scene,  // each model descriptor to its k nearest scene descriptors (paper Algorithm 4):
                     // lets one model keypoint match several instances
};

// How the nearest descriptors are found. scan and kdtree (FLANN's) are exact and find the same
// neighbours but for ties (the scan keeps the lower index); scan is the faster in 352 dimensions,
// where a kd-tree visits nearly every leaf. randomized: FLANN's randomized kd-trees, approximate
// and not reproducible: FLANN 1.9 shuffles their input with std::random_device, which no seed
// reaches.
enum class MatchSearch { scan, kdtree, randomized };

enum class Grouping { hough, gc };

struct MatchParams {
    MatchDirection direction = MatchDirection::model_to_scene;
    int k = 10;                     // neighbours per query in model_to_scene
    float threshold = 0.25f;        // d_max^2: squared descriptor distance accepted
    MatchSearch search = MatchSearch::scan;
    int trees = 4;                  // randomized kd-trees (approximate)
    int checks = 256;               // leaves visited per query (approximate)
};

struct GroupingParams {
    Grouping method = Grouping::hough;
    float hough_bin = 0.01f;        // L_h: Hough bin size (metres)
    float hough_threshold = 3.0f;   // V_h: minimum interpolated votes of a maximum
    float gc_size = 0.01f;          // GC: consensus distance (metres)
    int gc_threshold = 5;           // GC: minimum cluster size
    float ransac_distance = 0.01f;  // inlier distance of the per-instance pose fit (metres)
    int ransac_iterations = 500;
};

struct RefineParams {
    bool enabled = true;            // ICP of each instance onto the scene
    int iterations = 20;
    float max_distance = 0.01f;     // pairs farther than this are ignored (metres)
    float model_voxel = 0.008f;     // the model is thinned to one point per voxel first (0: not)
};

struct VerifyParams {
    bool enabled = true;
    float inlier_distance = 0.005f;      // a model point fits when a scene point is this close
    float min_inlier_fraction = 0.4f;    // of the model points the sensor could see (facing it, not hidden)
    float min_coverage = 0.6f;           // inliers / model points facing the camera: how much of that side the scene explains
    // A model point faces the sensor when its surface is turned less than 75 degrees from the ray
    // (this is cos 75°): a depth sensor gets little or no return from a more oblique surface (the
    // synthetic scanner: none beyond 80°). Where no return came back, a carton with one side nearly
    // edge on had over 40% of its facing points unmatched at its true pose and was refused for
    // coverage. On 40 synthetic scenes 75° and 80° find the same cartons; 70° finds 2 of 160 fewer.
    float min_facing_cos = 0.2588f;
    // Before ICP, a hypothesis whose facing points have a scene point within the ICP distance for
    // less than this fraction of min_coverage is dropped: most Hough maxima in clutter are such,
    // and true ones start within a centimetre.
    float prefilter_coverage = 0.75f;
    // The fitting model points must be about as far from flat as the whole side of the model turned
    // to the sensor: their thickness (spread off their best plane) over that side's. A model face
    // laid flush on a table fits it perfectly while the rest of the model, under the table, is
    // hidden, so neither fitness nor free space refutes it. A flat side (under 2 mm) passes.
    float min_thickness_ratio = 0.5f;
    float flat_side = 0.002f;            // a facing side thinner than this (metres) is flat and passes
    // Rim probes 1.5 cm beyond the edges of the fitting part of the model: the fraction where the
    // scene's surface goes on (of those where it goes on or the sensor sees past them). A pose
    // slid along the object's face, or turned on it, leaves part of the object unexplained just
    // beyond its edges; a true pose ends where the object does. 1: off.
    float max_continuation = 0.1f;
    // The probes lie this far (metres) from the fitting model points, in their tangent planes:
    // beyond sensor noise and the thinned model's spacing (a curved surface strays only r^2 / 2R
    // from its tangent plane: 3 mm on a bottle of 7 cm). A pose slid along a face by less than
    // rim_distance - inlier_distance is not seen by them.
    float rim_distance = 0.015f;
    // Fewer settled probes than this (a bottle's only rims are its cap and base, a few probes seen
    // from most sides) are too little evidence to reject an instance on.
    int min_rim_probes = 20;
    float free_space_margin = 0.01f;     // a model point this far in front of the observed surface
    float max_free_space_fraction = 0.1f;  // ... on this fraction of points rejects the instance
    // An accepted instance explaining at least this fraction of its visible points is settled: no
    // other pose of the object fits much better (the shared scenes' cartons: 1.0), and hypotheses
    // overlapping it are not verified. Poses slid along a flat face still explain most of it (a box
    // slid 12 mm along its 10 cm side: 0.96), hence a bar this high.
    float settled_fitness = 0.99f;
    bool merge = true;                   // merge instances whose placed models overlap:
    float merge_distance = 0.01f;        // ... points closer than this (metres) overlap,
    float merge_overlap = 0.2f;          // ... and this fraction of overlapping points merges
};

struct RecognitionParams {
    // The built-in defaults (README, "Recognition parameters", where the measurements are). Both
    // clouds are described at one working resolution, 5 mm: coarser than a depth sensor's pixel
    // footprint over its working range, so what is described does not depend on the sensor or the
    // distance. Every support is then metric: normals from 30 resampled points (a disc of about
    // 3 voxels' radius, wide enough to average the depth noise of far objects), scene keypoints 3
    // voxels apart, model keypoints 2, frames and descriptors over 4 cm (larger than the PCL
    // tutorial's 0.015 / 0.02, so they survive sensor noise).
    FeatureParams scene{0.005f, 30, 0.015f, 0.04f, 0.04f};
    FeatureParams model{0.005f, 30, 0.01f, 0.04f, 0.04f};
    // A foveated scene is described at its levels' densities, as a plain one at the resolution: its normals
    // come from the foveated cloud (on the synthetic sets: 164 of 215 visible instances and 5 false,
    // against 158 and 8 from the full scene's raw points).
    NormalsFrom normals_from = NormalsFrom::foveated;
    MatchParams match;
    GroupingParams grouping;
    RefineParams refine;
    VerifyParams verify;
};

// Parses parameters JSON (every key optional, defaults above; unknown keys and wrong types are
// errors naming "source: key"). Layout and key names: README, "Recognition parameters".
RecognitionParams parse_recognition_params(std::string_view json_text, const std::string& source);
RecognitionParams read_recognition_params(const std::filesystem::path& path);
std::string to_json(const RecognitionParams& params);
std::string to_json(const FeatureParams& params);  // the "scene" / "model" block alone
// Throws mfpc::Error naming the field of any value out of range.
void check_recognition_params(const RecognitionParams& params, const std::string& source = "params");

const char* to_string(NormalsFrom value);
const char* to_string(MatchDirection value);
const char* to_string(MatchSearch value);
const char* to_string(Grouping value);

}  // namespace mfpc
