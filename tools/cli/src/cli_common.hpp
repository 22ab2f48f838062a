#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <utility>

#include "mfpc/core/detail/text_format.hpp"
#include "mfpc/batch/batch.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/recognition/placement.hpp"

namespace CLI {
class App;
}

namespace mfpc::cli {

// Options every command sees.
struct GlobalOptions {
    int threads = 0;        // 0: all cores
    std::string json_path;  // "" none, "-" stdout
    bool quiet = false;
};

// True when the human-readable output should go to stdout (it yields stdout to --json -).
inline bool print_table(const GlobalOptions& global) { return !global.quiet && global.json_path != "-"; }

// The document as indented JSON text with a final newline. Strings that are not UTF-8 (a file name
// in another encoding, which a file system allows) get U+FFFD for their bad bytes instead of
// failing the whole write after the work is done.
std::string json_text(const nlohmann::ordered_json& document);

// Writes the machine-readable result: to stdout for "-", else atomically to the file.
void write_json(const GlobalOptions& global, const nlohmann::ordered_json& result);
// The same for a result the library already wrote as JSON text.
void write_json(const GlobalOptions& global, const std::string& text);

// The worker threads this run may use (--threads, else all cores).
int active_threads();

void warn(const std::string& message);

// The recognition parameters of --params PATH (the built-in set for none): `model` and
// `recognize` read them the same way.
RecognitionParams load_params(const std::string& path);

// The models of --model for batch and scaling, named by file stem (records name them so): two
// of one stem are a usage error. Without --params a cache brings its own model parameters.
std::vector<BatchModel> load_batch_models(const std::vector<std::string>& files, const RecognitionParams& params,
                                          const std::string& params_file);

// The exit status of a command that finished but not wholly (batch: 3 when some scenes failed);
// main returns it, 0 unless a command set it.
void set_exit_status(int status);
int exit_status();

// Warns when a ground truth names a model other than the one being found (their file names differ
// but for the extension: milk.pcd and milk.mfpcm are one model): scoring against another object's
// poses is silently wrong. `model_file` is the model cloud's path (a cache's source); either name
// empty checks nothing.
// Whether a ground truth naming `truth_model` is that of the model file (their names equal but for
// the extension: milk.pcd and milk.mfpcm are one model); true when either name is empty.
bool truth_is_of(const std::string& truth_model, const std::string& model_file);

void warn_if_truth_of_another_model(const std::string& truth_model, const std::string& model_file,
                                    const std::string& truth_file);

// --placement and --write-fovea, which go with `--fovea auto` (or `--config auto`).
struct PlacementOptions {
    std::string strategy = "segments";
    std::string write_fovea;
};
void add_placement_options(CLI::App* command, PlacementOptions& options, const std::string& fovea_option);

// Whether a fovea option asks for automatic placement.
inline bool is_auto_fovea(const std::string& value) { return value == "auto"; }

// Refuses --placement / --write-fovea given without `fovea_option auto`, before any work.
void check_placement_options(const PlacementOptions& options, bool automatic, const std::string& fovea_option);

// Automatic placement for a command: places, warns a fallback, writes --write-fovea (atomically;
// nothing when nothing was placed, which the warning says).
PlacementResult place_for_command(const PointCloud& scene, std::span<const Model* const> models,
                                  const RecognitionParams& params, const PlacementOptions& options,
                                  std::span<const PlacedInstance> truth = {});

// --fovea FILE|auto, --placement and --sequence of `batch` and `scaling`: every scene foveated with
// one config, each placing its own, or the scenes as the frames of one sequence (placement track).
struct BatchFoveaOptions {
    std::string fovea;      // a config file, "auto", or empty (plain)
    std::string placement;  // empty: segments with --fovea auto, track with --sequence
    bool sequence = false;
};
void add_batch_fovea_options(CLI::App* command, BatchFoveaOptions& options);

// Refuses contradictory options (usage errors, before any work), then sets job.fovea (the file
// read into `config`, which must outlive the job; its repairs warned) or job.placement.
void apply_batch_fovea_options(const BatchFoveaOptions& options, BatchJob& job, FoveationConfig& config);

using detail::format_fixed;
using detail::group_digits;

// "640x480" -> (640, 480); throws CLI::ValidationError naming `option` for anything else or a side
// outside 1..max_side.
std::pair<std::uint32_t, std::uint32_t> parse_size(const std::string& text, const std::string& option,
                                                   std::uint32_t max_side = 16384);

// "a,b,,c" -> {"a", "b", "c"}: a comma-separated option's items, empty ones dropped.
std::vector<std::string> split_list(const std::string& text);

// A two-column table with aligned keys.
void print_rows(const std::vector<std::pair<std::string, std::string>>& rows);

// A progress bar on stderr with the rate and the time left, redrawn in place on a terminal; in a
// log (stderr not a terminal) a plain line every 10 seconds and at the end.
class Progress {
public:
    void draw(std::size_t done, std::size_t total, const std::string& what);

private:
    std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
    std::chrono::steady_clock::time_point last_line_ = start_;
};

class Stopwatch {
public:
    double lap_ms()
    {
        const auto now = std::chrono::steady_clock::now();
        const double ms = std::chrono::duration<double, std::milli>(now - last_).count();
        last_ = now;
        return ms;
    }

private:
    std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

}  // namespace mfpc::cli
