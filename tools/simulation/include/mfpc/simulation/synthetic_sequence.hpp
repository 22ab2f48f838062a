#pragma once

/// @file
/// @brief Synthetic sequences: a sensor moving around a table of fixed objects, frame by frame,
/// with exact ground truth in every frame's camera frame (what `mfpc synth --sequence` writes).

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mfpc/core/pose.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"
#include "mfpc/simulation/virtual_scanner.hpp"

namespace mfpc {

/// @brief How the camera of a synthetic sequence moves.
///
/// The objects are composed once (compose_scene); then the camera orbits the objects' centre
/// (objects_centre) at the composed camera's distance and elevation, its heading turning by
/// arc_deg / (frames - 1) degrees a frame, counter-clockwise seen from above (the camera walks to
/// its right), so frame 0 is the composed view and the last frame has turned by arc_deg. The
/// defaults, 60 degrees over 30 frames (2.07 degrees a frame: the camera moves 1.4 to 2.8 cm
/// between frames at the composer's default distances and elevations), are a hand-held or
/// robot-mounted sensor at 30 Hz walking a sixth of the way around the table: a small motion from
/// frame to frame, which a tracker may exploit.
struct SequenceParams {
    std::uint32_t frames = 30;  ///< Frames in the sequence, 2..10000 (default 30).
    /// Degrees the heading turns from the first frame to the last, finite, in (0, 360] (default 60).
    float arc_deg = 60.0f;
};

/// @brief Checks a sequence's parameters.
/// @param params The parameters.
/// @throws mfpc::Error naming the field ("frames" or "arc_deg") for frames outside 2..10000 or an
/// arc that is not finite or not in (0, 360].
void check_sequence_params(const SequenceParams& params);

/// @brief The turn of the camera's heading from one frame to the next.
/// @param params The parameters (not checked).
/// @return arc_deg / (frames - 1), in degrees.
double sequence_heading_step_deg(const SequenceParams& params);

/// @brief The camera of frame `frame`: the scene's camera turned about the vertical axis through
/// objects_centre(scene) by frame * sequence_heading_step_deg(params) degrees. It keeps the
/// distance to that point, the elevation above the table and the level of its x axis, and goes on
/// looking at the point. Frame 0's camera is the scene's camera, bit for bit.
/// @param scene The composed scene (its camera is frame 0's).
/// @param params The sequence's parameters.
/// @param frame The frame, 0 the first.
/// @return Camera frame -> world frame.
/// @throws mfpc::Error as check_sequence_params, or naming "frame" for a frame the sequence does
/// not have.
Pose sequence_camera(const SyntheticScene& scene, const SequenceParams& params, std::uint32_t frame);

/// @brief The seed of a frame's sensor noise: `seed` for frame 0 (so frame 0 is the scan
/// `mfpc synth --seed S` makes), a different one for every other frame (seed + frame times
/// 0x9E3779B9, modulo 2^32), so the noise differs from frame to frame.
/// @param seed The composer's seed.
/// @param frame The frame.
/// @return The seed.
std::uint32_t sequence_frame_seed(std::uint32_t seed, std::uint32_t frame);

/// @brief Frame `frame` of a sequence: the scene with the camera moved (sequence_camera), scanned
/// with the frame's noise seed (sequence_frame_seed), one fovea per instance in that frame's camera
/// frame, and the instances' visible fractions (visible_fraction_of), as a scene of `mfpc
/// synth-set` has them. The dataset's seed is the composer's; its frame says where it stands. Its
/// models are left empty (a sequence writes them once: write_synthetic_sequence).
/// @param scene The composed scene.
/// @param sensor The sensor.
/// @param seed The composer's seed.
/// @param params The sequence's parameters.
/// @param frame The frame, 0 the first.
/// @return The frame's dataset.
/// @throws mfpc::Error as sequence_camera and scan_synthetic_scene.
SyntheticDataset make_sequence_frame(const SyntheticScene& scene, const SensorParams& sensor, std::uint32_t seed,
                                     const SequenceParams& params, std::uint32_t frame);

/// @brief The directory of a frame within a sequence's: `frame_NNN`, the index padded with zeros
/// to 3 digits (more when the sequence has more than 1000 frames), so names sort in frame order.
/// @param frame The frame.
/// @param frames The frames in the sequence.
/// @return The directory's name.
std::string sequence_frame_directory(std::uint32_t frame, std::uint32_t frames);

/// @brief Called after the models and after each frame written: steps done, steps in all (1 +
/// the frames).
using SequenceProgress = std::function<void(std::size_t done, std::size_t total)>;

/// @brief Writes a synthetic sequence into `directory` (created if missing), every file
/// atomically. Composes the scene once (compose_scene: shapes[0] to recognise, the others as
/// distractors), then writes:
///
///     <shape>.pcd      each shape's model cloud, once (as write_synthetic_models)
///     <object>.mfpcm   the model cache of the object to recognise, described once from views
///     frame_NNN/       per frame (sequence_frame_directory), what write_synthetic_scene_files
///                      writes of make_sequence_frame: scene.pcd, scene.gt.json (ground truth in
///                      that frame's camera frame, with visible fractions; its model
///                      ../<shape>.pcd), labels.png, scene.json (with "frame": index, noise_seed,
///                      heading_deg), fovea.json and fovea_all.json (with instances)
///     dataset.json     the manifest `mfpc evaluate --dataset` reads: the model cache, then the
///                      frames in order, each of group "sequence" with its fovea
///     frames.txt       one scene cloud a line (frame_NNN/scene.pcd), in frame order, the list
///                      `mfpc batch --scenes` reads
///
/// The same arguments give the same bytes on any thread count.
/// @param directory The sequence's directory; its name is the manifest's.
/// @param shapes The shape to recognise first, then the distractor shapes.
/// @param compose The composer's parameters (its seed keys frame 0's noise, see sequence_frame_seed).
/// @param sensor The sensor.
/// @param sequence How the camera moves.
/// @param model_spacing The spacing of the shapes' model clouds (as make_synthetic_dataset).
/// @param features How the object to recognise is described.
/// @param progress When given, called after the models and after each frame written.
/// @throws mfpc::Error, before any work, for parameters check_sequence_params refuses, a sensor
/// check_sensor refuses, a model spacing check_model_spacing refuses or a directory that cannot be
/// made; then as compose_scene, a frame whose objects lie beyond the sensor's max_range (checked
/// for every frame before the first is scanned), the scans, describing the object and writing.
void write_synthetic_sequence(const std::filesystem::path& directory, std::vector<SceneShape> shapes,
                              const ComposeParams& compose, const SensorParams& sensor,
                              const SequenceParams& sequence, float model_spacing = 0.002f,
                              const FeatureParams& features = RecognitionParams{}.model,
                              const SequenceProgress& progress = {});

}  // namespace mfpc
