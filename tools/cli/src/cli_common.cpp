#include "cli_common.hpp"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>

#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/recognition/model.hpp"

namespace mfpc::cli {

std::string json_text(const nlohmann::ordered_json& document)
{
    return document.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + '\n';
}

void write_json(const GlobalOptions& global, const nlohmann::ordered_json& result)
{
    if (!global.json_path.empty()) write_json(global, json_text(result));
}

void write_json(const GlobalOptions& global, const std::string& text)
{
    if (global.json_path.empty()) return;
    if (global.json_path == "-") {
        std::cout << text;
        return;
    }
    write_file_atomically(global.json_path, [&](std::ofstream& out) { out << text; });
}

int active_threads()
{
    return int(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

void Progress::draw(std::size_t done, std::size_t total, const std::string& what)
{
    done = std::min(done, total);
    const auto now = std::chrono::steady_clock::now();
    const bool terminal = isatty(STDERR_FILENO);
    if (!terminal && done != total && now - last_line_ < std::chrono::seconds(10)) return;
    last_line_ = now;
    const double seconds = std::chrono::duration<double>(now - start_).count();
    const double rate = seconds > 0 ? double(done) / seconds : 0.0;
    std::string timing = format_fixed(seconds, 0) + " s";
    if (done > 0 && done < total) timing += ", " + format_fixed(double(total - done) / rate, 0) + " s left";
    constexpr std::size_t width = 30;
    const std::size_t filled = total > 0 ? done * width / total : width;
    std::cerr << (terminal ? "\r[" : "[") << std::string(filled, '#') << std::string(width - filled, '.') << "] " << done
              << "/" << total << "  " << format_fixed(rate, 2) << "/s  " << timing << "  " << what
              << (terminal ? "    " : "\n") << std::flush;
    if (terminal && done == total) std::cerr << '\n';
}

std::vector<std::string> split_list(const std::string& text)
{
    std::vector<std::string> items;
    std::stringstream stream(text);
    for (std::string item; std::getline(stream, item, ',');)
        if (!item.empty()) items.push_back(item);
    return items;
}

namespace {
int command_exit_status = 0;
}  // namespace

RecognitionParams load_params(const std::string& path)
{
    return path.empty() ? RecognitionParams{} : read_recognition_params(path);
}

std::vector<BatchModel> load_batch_models(const std::vector<std::string>& files, const RecognitionParams& params,
                                          const std::string& params_file)
{
    std::vector<BatchModel> models;
    for (const std::string& file : files) {
        BatchModel model{std::filesystem::path(file).stem().string(),
                         load_model(file, params.model, !params_file.empty(), params_file)};
        prepare_model_verification(model.model, params);
        for (const BatchModel& other : models)
            if (other.name == model.name)
                throw CLI::ValidationError("--model", "two models named '" + model.name +
                                                          "': records name models by file stem");
        models.push_back(std::move(model));
    }
    return models;
}

void set_exit_status(int status) { command_exit_status = status; }
int exit_status() { return command_exit_status; }

void warn(const std::string& message) { std::cerr << "mfpc: warning: " << message << '\n'; }

bool truth_is_of(const std::string& truth_model, const std::string& model_file)
{
    return truth_model.empty() || model_file.empty() ||
           std::filesystem::path(truth_model).stem() == std::filesystem::path(model_file).stem();
}

void warn_if_truth_of_another_model(const std::string& truth_model, const std::string& model_file,
                                    const std::string& truth_file)
{
    if (truth_is_of(truth_model, model_file)) return;
    warn(truth_file + " is the ground truth of model " + truth_model + ", not of " +
         std::filesystem::path(model_file).filename().string() + ": the evaluation scores against that model's poses");
}

std::pair<std::uint32_t, std::uint32_t> parse_size(const std::string& text, const std::string& option,
                                                   std::uint32_t max_side)
{
    const std::size_t x = text.find('x');
    auto side = [&](const std::string& digits) -> std::uint32_t {
        if (digits.empty() || digits.size() > 6 || digits.find_first_not_of("0123456789") != std::string::npos) return 0;
        const unsigned long value = std::stoul(digits);
        return value <= max_side ? std::uint32_t(value) : 0;
    };
    const std::uint32_t width = x == std::string::npos ? 0 : side(text.substr(0, x));
    const std::uint32_t height = x == std::string::npos ? 0 : side(text.substr(x + 1));
    if (width == 0 || height == 0)
        throw CLI::ValidationError(option, "'" + text + "' is not WIDTHxHEIGHT with sides 1.." + std::to_string(max_side));
    return {width, height};
}

void print_rows(const std::vector<std::pair<std::string, std::string>>& rows) { std::cout << detail::key_value_rows(rows); }

void add_placement_options(CLI::App* command, PlacementOptions& options, const std::string& fovea_option)
{
    command->add_option("--placement", options.strategy,
                        "With " + fovea_option + " auto: how the structures are placed: segments (default: supporting "
                        "planes removed, one structure per object-sized cluster), coarse (hypotheses of a cheap "
                        "recognition pass), grid (the paper's uniform distribution), track (as segments for one "
                        "cloud), oracle (from --ground-truth)")
        ->check(CLI::IsMember({"segments", "coarse", "grid", "track", "oracle"}));
    command->add_option("--write-fovea", options.write_fovea,
                        "With " + fovea_option + " auto: write the placed foveation config here, to reproduce the "
                        "run or draw it with `mfpc render`")
        ->type_name("FOVEA.json");
}

void check_placement_options(const PlacementOptions& options, bool automatic, const std::string& fovea_option)
{
    if (automatic) return;
    if (options.strategy != "segments") throw CLI::ValidationError("--placement", "needs " + fovea_option + " auto");
    if (!options.write_fovea.empty()) throw CLI::ValidationError("--write-fovea", "needs " + fovea_option + " auto");
}

PlacementResult place_for_command(const PointCloud& scene, std::span<const Model* const> models,
                                  const RecognitionParams& params, const PlacementOptions& options,
                                  std::span<const PlacedInstance> truth)
{
    PlacementParams placement;
    placement.strategy = parse_placement_strategy(options.strategy, "--placement");
    PlacementTrack track;
    PlacementResult result = place_foveae(scene, models, params, placement, truth,
                                          placement.strategy == PlacementStrategy::track ? &track : nullptr);
    if (!result.fallback.empty()) {
        warn(result.fallback + (options.write_fovea.empty() ? "" : "; nothing written to " + options.write_fovea));
    } else if (!options.write_fovea.empty()) {
        const std::string text = to_json(result.config);
        write_file_atomically(options.write_fovea, [&](std::ofstream& out) { out << text; });
    }
    return result;
}

void add_batch_fovea_options(CLI::App* command, BatchFoveaOptions& options)
{
    command->add_option("--fovea", options.fovea,
                        "Foveate every scene with this config (mfpc mode) first; `auto`: each scene's structures "
                        "placed from it and every model (see --placement), the scene running plain where none is "
                        "placed")
        ->type_name("FOVEA.json|auto");
    command->add_option("--placement", options.placement,
                        "With --fovea auto: segments (default: supporting planes removed, one structure per "
                        "object-sized cluster), coarse (hypotheses of a cheap recognition pass) or grid (the "
                        "paper's uniform distribution); track goes with --sequence")
        ->type_name("NAME");
    command->add_flag("--sequence", options.sequence,
                      "The scenes are the frames of one sequence, in their order (a folder's or glob's by name, a "
                      "list's as listed): each frame's foveae follow the instances of the frames before (--fovea "
                      "auto --placement track). The frames run one after another, the work within each in "
                      "parallel, in one process (not under mpirun)");
}

void apply_batch_fovea_options(const BatchFoveaOptions& options, BatchJob& job, FoveationConfig& config)
{
    const bool automatic = is_auto_fovea(options.fovea);
    if (options.sequence) {
        if (!options.fovea.empty() && !automatic)
            throw CLI::ValidationError("--sequence", "places each frame's foveae itself: not with --fovea " +
                                                         options.fovea);
        if (!options.placement.empty() && options.placement != "track")
            throw CLI::ValidationError("--sequence", "places with track: not with --placement " + options.placement);
    } else if (!options.placement.empty()) {
        if (!automatic) throw CLI::ValidationError("--placement", "needs --fovea auto");
        if (options.placement == "track")
            throw CLI::ValidationError("--placement track",
                                       "follows the instances from frame to frame: pass --sequence");
        if (options.placement == "oracle")
            throw CLI::ValidationError("--placement oracle", "needs each scene's ground truth: not for a batch");
        if (options.placement != "segments" && options.placement != "coarse" && options.placement != "grid")
            throw CLI::ValidationError("--placement", "'" + options.placement + "' is not one of segments, coarse, "
                                                      "grid (or track with --sequence)");
    }
    if (options.sequence || automatic) {
        PlacementParams placement;
        placement.strategy = options.sequence        ? PlacementStrategy::track
                             : options.placement.empty() ? PlacementStrategy::segments
                                                         : parse_placement_strategy(options.placement, "--placement");
        job.placement = placement;
    } else if (!options.fovea.empty()) {
        std::vector<std::string> warnings;
        config = read_foveation_config(options.fovea, FoveaPolicy::clamp, &warnings);
        for (const auto& w : warnings) warn(w);
        job.fovea = &config;
    }
}

}  // namespace mfpc::cli
