#pragma once

/// @file
/// @brief Automatic fovea placement: a foveation config proposed from a cloud and the models to
/// find in it, so that multifoveation needs no hand-written config per scene (the problem the
/// paper leaves open in its Sections 8 and 9).

#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "mfpc/core/box.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/core/pose.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

/// @brief How the structures are placed.
enum class PlacementStrategy {
    /// Supporting planes removed, what stands on them clustered, one structure per object-sized
    /// cluster. Assumes objects stand apart from (not inside) clutter larger than themselves.
    segments,
    /// A cheap recognition pass (coarse scene, no refinement or verification) whose hypotheses
    /// seed the structures. Assumes the models' descriptors survive the coarse density.
    coarse,
    /// The paper's uniform distribution: cells of one model extent tiling the scene's bounds, one
    /// structure per occupied cell. Assumes nothing; saves little.
    grid,
    /// For a sequence of frames: segments' clusters only where the instances of the frames before
    /// were (within PlacementParams::track_margin, for the motion between frames), and all of them
    /// every PlacementParams::track_refresh frames, or whenever nothing is followed, for what is
    /// new. Assumes the objects move little in the sensor's frame from one frame to the next.
    track,
    /// Structures built from the ground truth (each instance's placed model), sized as the others
    /// are: what placement would give if it knew where the objects are.
    oracle,
};

/// @brief The name of a strategy, as parse_placement_strategy reads it.
/// @param strategy The strategy.
/// @return "segments", "coarse", "grid", "track" or "oracle".
const char* to_string(PlacementStrategy strategy);

/// @brief The strategy named by `text`.
/// @param text "segments", "coarse", "grid", "track" or "oracle".
/// @param where The name of the setting, for the error.
/// @return The strategy.
/// @throws mfpc::Error naming `where` for any other text.
PlacementStrategy parse_placement_strategy(std::string_view text, const std::string& where = "placement");

/// @brief What automatic placement does. Sizes are metres. Every default holds whatever the
/// sensor: the working cloud is resampled at `voxel` first, so densities and distances are
/// metric, and the structures are sized from the models, not from the scene.
struct PlacementParams {
    PlacementStrategy strategy = PlacementStrategy::segments;  ///< How the structures are placed.
    /// m of every structure. Three levels, as the paper's experiments and the shipped configs:
    /// the fovea, and two rings of context that the descriptors at the fovea's edge reach into.
    int levels = 3;
    /// The fovea is the object's box (a cluster's, a hypothesis's or an instance's) grown by this
    /// on every side: beyond the plane's inlier band, so the object's foot is described at the
    /// fovea's density too.
    float fovea_margin = 0.02f;
    /// The outer box is the fovea grown by this on every side: one SHOT support (4 cm by default)
    /// and more, so keypoints at the fovea's edge see their neighbourhood at some density.
    float outer_margin = 0.08f;
    /// The outer density d_0 is this many times the fovea's d_m (the scene's working resolution),
    /// and the outer keypoint radius r_0 this many times r_m (the scene's keypoint radius):
    /// context, not detail (2 cm and 6 cm by default; the shipped configs: 2 cm and 3 cm). At resolution
    /// 0 (the cloud as sampled) every point of the fovea is kept and d_0 is the scene's keypoint
    /// radius.
    float outer_density_factor = 4.0f;
    /// The working cloud of segments, grid and track: one point per voxel of this edge. Twice the
    /// default working resolution: finer than the smallest object part worth a structure, coarse
    /// enough that a VGA scene is some 10,000 voxels.
    float voxel = 0.01f;
    /// A plane inlier lies this close to it: a Kinect's noise at 1.5 m (3 sigma about 1 cm) and
    /// half a voxel.
    float plane_distance = 0.015f;
    /// The most supporting planes removed (a table, the floor, a wall behind).
    int max_planes = 3;
    /// A plane is removed only when it holds at least this fraction of the working cloud's
    /// voxels that are left ...
    float min_plane_fraction = 0.1f;
    /// ... and its piece is longer than this many times the largest model's extent (its box's
    /// diagonal) in some direction: no face of a model is longer than its diagonal, so such a
    /// piece is a support, not an object's face. (A stereo rig's narrow view sees a strip of table
    /// 64 by 25 cm beside a carton of 25 cm diagonal: the strip's width alone does not tell.)
    float min_plane_span = 1.0f;
    /// RANSAC draws per plane (three voxels each, from a fixed seed: the same planes whatever the
    /// threads).
    int plane_iterations = 256;
    /// Voxels closer than this (centre to centre, along each axis) join one cluster: the same
    /// object, one voxel of gap allowed for sensor dropouts.
    float cluster_gap = 0.02f;
    /// A cluster of fewer voxels (about 10 cm² of surface at 1 cm) is noise or a sliver of an
    /// object, too little to recognise ...
    int min_cluster_voxels = 10;
    /// ... and so is one of fewer voxels than this fraction of the smallest model's (its points at
    /// `voxel`): an object half hidden still shows about a quarter of its whole surface.
    float min_cluster_share = 0.1f;
    /// segments, coarse and track: when the foveae would hold more than this fraction of the
    /// working cloud, foveation costs more than it saves (the fovea is described as densely as
    /// the plain pipeline describes everything, and the outer levels come on top), so nothing is
    /// placed and the scene runs plain (a cluttered room: hundreds of object-sized clusters).
    float max_fovea_fraction = 0.5f;
    /// A cluster whose box is longer than this many times the largest model's extent (its box's
    /// diagonal) on some axis is not one object but clutter, furniture or several objects, and
    /// gets no structure (counted in PlacementResult::clusters_too_large).
    float max_cluster_factor = 1.5f;
    /// coarse: the scene's working resolution and keypoint radius are this many times the scene
    /// parameters' (fewer, coarser keypoints; the model as described).
    float coarse_factor = 2.0f;
    /// coarse: hypotheses kept, strongest (most votes) first.
    int coarse_hypotheses = 10;
    /// grid: cell edge; 0 is the largest model's extent.
    float grid_cell = 0.0f;
    /// track: a segments pass looks for new objects every this many frames (and an instance not
    /// found again is followed for as many): 10 frames are a third of a second at 30 Hz.
    int track_refresh = 10;
    /// track: how far an object may move in the sensor's frame between two frames (a sensor
    /// turning 2 degrees a frame around objects 1 m away moves them 3.5 cm): a cluster whose
    /// centre lies within this of a followed instance's box is followed.
    float track_margin = 0.05f;
};

/// @brief Checks every placement parameter's range.
/// @param params The parameters.
/// @param source Names them in errors.
/// @throws mfpc::Error naming "source: key" for the first value out of range.
void check_placement_params(const PlacementParams& params, const std::string& source = "placement");

/// @brief An instance of a model in a frame, as track and oracle read it.
struct PlacedInstance {
    std::size_t model = 0;             ///< Index into the models given.
    Pose transform = Pose::Identity();  ///< Maps model coordinates into the scene.
};

/// @brief What track remembers from frame to frame. Start with a default-constructed state and pass
/// the same one to every frame, then tell it what recognition found in that frame (track_update).
struct PlacementTrack {
    std::uint64_t frame = 0;  ///< Frames placed so far.
    /// The instances followed: each one's box where it was last found, and that frame.
    std::vector<std::pair<Box, std::uint64_t>> followed;
};

/// @brief A proposed foveation config and how it came about.
struct PlacementResult {
    PlacementStrategy strategy = PlacementStrategy::segments;  ///< The strategy that ran.
    /// The structures (m = PlacementParams::levels, voxel downsampling); no structures when nothing
    /// could be placed (then `fallback` says why and the scene runs without foveation).
    FoveationConfig config;
    /// Empty when structures were placed; else why none were, and that the scene runs plain.
    std::string fallback;
    std::size_t planes = 0;              ///< Supporting planes removed (segments, track).
    /// Clusters large enough to recognise (min_cluster_voxels and min_cluster_share; segments, track).
    std::size_t clusters = 0;
    std::size_t clusters_too_large = 0;  ///< Of those, the ones longer than an object (no structure).
    std::size_t followed = 0;            ///< track: instances of the frames before that this frame follows.
    bool searched = false;               ///< track: whether this frame ran a segments pass for new objects.
    std::size_t hypotheses = 0;          ///< coarse: hypotheses of the coarse pass.
    /// Of the working cloud's voxels, the fraction inside some fovea (segments, coarse, track;
    /// before the max_fovea_fraction fallback).
    double fovea_fraction = 0;
    std::vector<Box> objects;            ///< The object box each structure was placed around, in order.
    double ms = 0;                       ///< Wall time of the placement.
};

/// @brief Proposes a foveation config for a scene and the models to find in it (see
/// PlacementStrategy). Deterministic: the same cloud and parameters give the same config at any
/// thread count.
///
/// Every structure is sized the same way, whatever the strategy: the fovea is the object's box
/// grown by fovea_margin; the outer box the fovea grown by outer_margin; d_m and r_m are the
/// scene's working resolution and keypoint radius (so the fovea is described as the plain pipeline
/// describes the whole scene), d_0 and r_0 outer_density_factor times as coarse.
/// @param scene The scene cloud (non-finite points are ignored).
/// @param models The models to find (none may be null; at least one).
/// @param recognition The recognition parameters the scene will run with (its scene side sizes the
/// structures; coarse runs its pass with them).
/// @param params The placement parameters.
/// @param truth oracle: the instances to place structures around; unused by the others.
/// @param track track: the state carried from frame to frame; null for the other strategies.
/// @return The config and how it was found. A scene where nothing can be placed gives no
/// structures and says why in `fallback`: no point, no plane, no cluster or no hypothesis is never
/// an error.
/// @throws mfpc::Error for parameters out of range (check_placement_params,
/// check_recognition_params), no models or a null one, a model without points or no larger than
/// `voxel`, a point too far out for voxel_grid (2^30 voxels), track without a
/// state, or an oracle instance naming a model not given.
PlacementResult place_foveae(const PointCloud& scene, std::span<const Model* const> models,
                             const RecognitionParams& recognition, const PlacementParams& params,
                             std::span<const PlacedInstance> truth = {}, PlacementTrack* track = nullptr);

/// @brief Tells track what recognition found in the frame just placed: each instance is followed
/// from its box (replacing the followed box it overlaps), and one not found again for
/// track_refresh frames is dropped.
/// @param track The state place_foveae(track) updated for this frame.
/// @param models The models, as given to place_foveae.
/// @param instances The instances found in the frame.
/// @param refresh PlacementParams::track_refresh of the placement.
/// @throws mfpc::Error for an instance naming a model not given, or a refresh outside 1..1000000.
void track_update(PlacementTrack& track, std::span<const Model* const> models,
                  std::span<const PlacedInstance> instances, int refresh = PlacementParams{}.track_refresh);

/// @brief The box, in the scene, of a model placed by `transform`: its points' box.
/// @param model The model.
/// @param transform Maps model coordinates into the scene.
/// @return The box of the transformed model points.
Box placed_model_box(const Model& model, const Pose& transform);

/// @brief A model's extent: the diagonal of its points' box, the longest it can be along any axis
/// whatever its pose.
/// @param model The model.
/// @return The diagonal (metres).
float model_extent(const Model& model);

/// @brief How a placement went, as JSON: strategy, structures, the counts, time and fallback (the
/// config itself is to_json(result.config)).
/// @param result The placement.
/// @return Indented JSON text with a final newline.
std::string to_json(const PlacementResult& result);

/// @brief How a placement went, in one line: "segments: 5 structures (1 plane, 7 clusters, 2
/// longer than an object), 12.3 ms".
/// @param result The placement.
/// @return The line, without a newline.
std::string summary(const PlacementResult& result);

/// @brief The placement parameters as JSON (every key), for reports.
/// @param params The parameters.
/// @return Indented JSON text with a final newline.
std::string to_json(const PlacementParams& params);

}  // namespace mfpc
