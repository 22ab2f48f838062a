#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"

namespace mfpc {

/// The scene `mfpc demo` synthesizes.
struct DemoParams {
    std::uint32_t seed = 1;          ///< of the scene's layout and sensor noise
    std::uint32_t objects = 3;       ///< instances of the object to find
    std::uint32_t distractors = 3;   ///< other built-in objects
    std::string object = "carton";   ///< the built-in object to find
};

/// One way the demo recognised the scene.
struct DemoStrategy {
    std::string name;                ///< "plain" or "mfpc"
    RecognitionResult result;
    Evaluation evaluation;
};

/// What the demo made and found.
struct DemoRun {
    DemoParams params;
    std::filesystem::path directory;     ///< where the dataset and the picture went
    SyntheticDataset dataset;
    GroundTruth truth;
    std::vector<DemoStrategy> strategies;  ///< plain, then mfpc with one structure per instance
    std::filesystem::path image;         ///< the picture, once render_demo drew it
    double synthesize_ms = 0;
    double recognize_ms = 0;
    double render_ms = 0;
};

/// Synthesizes a tabletop scene (as `mfpc synth`), writes its dataset into `directory`, and
/// recognises the object in it with the default parameters, without foveation and with one
/// structure per instance. `progress` is told each step.
/// @throws mfpc::Error for an object that is not built in, or a directory that cannot be written
DemoRun run_demo(const DemoParams& params, const std::filesystem::path& directory,
                 const std::function<void(const std::string&)>& progress = {});

/// Draws the scene as foveated, with the instances the mfpc strategy found in red, into
/// demo.png in the run's directory, and sets `run.image` and `run.render_ms`.
/// @throws mfpc::Error when the picture cannot be written
void render_demo(DemoRun& run);

/// The run as JSON text: the scene, per strategy its counts, evaluation and time, the picture.
std::string to_json(const DemoRun& run);

/// The run as the text table `mfpc demo` prints.
std::string to_table(const DemoRun& run);

}  // namespace mfpc
