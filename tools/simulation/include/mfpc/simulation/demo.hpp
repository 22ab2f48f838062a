#pragma once

/// @file
/// @brief `mfpc demo`: a synthesized tabletop scene recognised plain, with automatically placed
/// foveae and with foveae placed from the ground truth, with a picture.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/placement.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"

namespace mfpc {

/// @brief The scene `mfpc demo` synthesizes.
struct DemoParams {
    std::uint32_t seed = 1;          ///< Of the scene's layout and sensor noise.
    std::uint32_t objects = 3;       ///< Instances of the object to find.
    std::uint32_t distractors = 3;   ///< Other built-in objects.
    std::string object = "carton";   ///< The built-in object to find.
};

/// @brief One way the demo recognised the scene.
struct DemoStrategy {
    std::string name;                ///< "plain", "auto" (segments placement) or "oracle" (placed from the ground truth).
    RecognitionResult result;        ///< What recognize() found.
    Evaluation evaluation;           ///< Its score against the scene's ground truth.
    std::optional<PlacementResult> placement;  ///< The foveae's placement (absent for plain).
    /// @brief The strategy's scene time: placement and recognition.
    /// @return Milliseconds.
    double ms() const { return result.timings.total + (placement ? placement->ms : 0.0); }
};

/// @brief What the demo made and found.
struct DemoRun {
    DemoParams params;                   ///< The scene asked for.
    std::filesystem::path directory;     ///< Where the dataset and the picture went.
    SyntheticDataset dataset;            ///< The synthesized scene, its scan and the model.
    GroundTruth truth;                   ///< The scene's ground truth.
    std::vector<DemoStrategy> strategies;  ///< Plain, auto, then oracle.
    std::filesystem::path image;         ///< The picture, once render_demo drew it.
    double synthesize_ms = 0;            ///< Synthesizing the scene and writing its dataset.
    double recognize_ms = 0;             ///< Placing and recognising, every strategy.
    double render_ms = 0;                ///< Drawing the picture.
};

/// @brief Synthesizes a tabletop scene (as `mfpc synth`), writes its dataset into `directory`, and
/// recognises the object in it with the default parameters: without foveation, with the structures
/// place_foveae proposes (segments, written to fovea_auto.json), and with structures placed the
/// same way around the ground truth's instances (the oracle: what placement would give knowing
/// where the objects are).
/// @param params The scene.
/// @param directory Where the dataset goes; created if missing.
/// @param progress When given, told each step.
/// @return The run, without its picture (render_demo draws it).
/// @throws mfpc::Error for an object that is not built in, or a directory that cannot be written,
/// or as make_synthetic_dataset, write_synthetic_dataset, recognize() and evaluate().
DemoRun run_demo(const DemoParams& params, const std::filesystem::path& directory,
                 const std::function<void(const std::string&)>& progress = {});

/// @brief Draws the scene with the automatically placed structures and the instances that strategy
/// found in red, into demo.png in the run's directory, and sets `run.image` and `run.render_ms`.
/// @param run A run of run_demo.
/// @throws mfpc::Error for a run without an "auto" strategy, or when the picture cannot be drawn or
/// written.
void render_demo(DemoRun& run);

/// @brief The run as JSON text: the scene, per strategy its counts, evaluation and time, the picture.
/// @param run The run.
/// @return Indented JSON text with a final newline.
std::string to_json(const DemoRun& run);

/// @brief The run as the text table `mfpc demo` prints.
/// @param run The run.
/// @return Text with a final newline.
std::string to_table(const DemoRun& run);

}  // namespace mfpc
