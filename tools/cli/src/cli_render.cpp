#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cli_commands.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/recognition_report.hpp"
#include "mfpc/rendering/png_image.hpp"
#include "mfpc/rendering/renderer.hpp"

namespace mfpc::cli {

namespace {

struct RenderOptions {
    std::string cloud;
    std::string fovea;
    std::string result;
    std::string view = "camera";
    std::string size;  // "WxH"; empty: the cloud's grid or 640x480
    float point_radius = 0.0f;
    std::string output;
};

std::vector<Point> model_points(const std::filesystem::path& model)
{
    if (is_model_cache(model)) return read_model_cache(model).points;
    return read_cloud(model).points;
}

void run_render(const RenderOptions& options, const GlobalOptions& global)
{
    // Everything that can be checked before the work is checked first.
    const std::filesystem::path output = options.output;
    if (output.extension() != ".png") throw CLI::ValidationError("--output", "the image must end in .png");
    const std::filesystem::path output_directory = output.parent_path().empty() ? "." : output.parent_path();
    std::error_code status_error;
    if (!std::filesystem::is_directory(output_directory, status_error))
        throw Error(options.output, "directory " + output_directory.string() + " does not exist");
    RenderParams params;
    params.view = parse_render_view(options.view);
    params.point_radius = options.point_radius;
    if (!options.size.empty()) std::tie(params.width, params.height) = parse_size(options.size, "--size");

    Stopwatch clock;
    Stopwatch total_clock;
    std::vector<std::string> warnings;
    FoveationConfig config;
    if (!options.fovea.empty()) config = read_foveation_config(options.fovea, FoveaPolicy::clamp, &warnings);
    for (const auto& w : warnings) warn(w);
    InstancePoses instances;
    std::vector<RenderOverlay> overlays;
    if (!options.result.empty()) {
        instances = read_instance_poses(options.result);
        const std::vector<Point> model = model_points(instances.model);
        for (const Pose& transform : instances.transforms) {
            RenderOverlay overlay;
            overlay.points.reserve(model.size());
            for (const Point& p : model) overlay.points.push_back(transform * p);
            overlays.push_back(std::move(overlay));
        }
    }
    const PointCloud cloud = read_cloud(options.cloud);
    const double read_ms = clock.lap_ms();

    RenderStats stats;
    const RgbImage image = render_cloud(cloud, options.fovea.empty() ? nullptr : &config, overlays, params, &stats);
    const double render_ms = clock.lap_ms();
    write_png(output, image);
    const double write_ms = clock.lap_ms();
    const double total_ms = total_clock.lap_ms();

    if (print_table(global)) {
        std::vector<std::pair<std::string, std::string>> rows = {
            {"cloud", options.cloud},
            {"view", to_string(params.view)},
            {"image", std::to_string(image.width) + "x" + std::to_string(image.height)},
            {"points", group_digits(stats.points)},
            {"point radius", format_fixed(stats.point_radius * 1000.0, 2) + " mm (median)"},
            {"boxes", std::to_string(stats.boxes) +
                          (options.fovea.empty() ? std::string() : " (" + std::to_string(config.structures.size()) +
                                                                       " structures)")},
            {"instances", std::to_string(instances.transforms.size()) +
                              (options.result.empty() ? std::string() : " (" + group_digits(stats.overlay_points) +
                                                                            " model points)")},
            {"output", options.output},
            {"time (ms)", "read " + format_fixed(read_ms, 1) + "  render " + format_fixed(render_ms, 1) + "  write " +
                              format_fixed(write_ms, 1)},
        };
        print_rows(rows);
    }
    write_json(global, {
        {"output", options.output},
        {"cloud", options.cloud},
        {"view", to_string(params.view)},
        {"width", image.width},
        {"height", image.height},
        {"points", stats.points},
        {"point_radius_m", stats.point_radius},
        {"boxes", stats.boxes},
        {"instances", instances.transforms.size()},
        {"overlay_points", stats.overlay_points},
        {"timings_ms", {{"read", read_ms}, {"render", render_ms}, {"write", write_ms}, {"total", total_ms}}},
        {"threads", active_threads()},
        {"warnings", warnings},
    });
}

}  // namespace

void add_render_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<RenderOptions>();
    CLI::App* command = app.add_subcommand(
        "render", "Draw a cloud to a PNG as in the paper's figures: points coloured by foveation region, level "
                  "boxes as wireframes, recognised instances in red");
    command->add_option("CLOUD", options->cloud, "Cloud to draw (.pcd or .ply), in the sensor's camera frame")
        ->required();
    command->add_option("--fovea", options->fovea,
                        "Foveation config (JSON): colour points by (structure, level) and draw every level box")
        ->type_name("FOVEA.json");
    command->add_option("--result", options->result,
                        "Result of `mfpc recognize --json` (or a ground truth): draw its instances in red")
        ->type_name("RESULT.json");
    command->add_option("--view", options->view,
                        "camera: the sensor's view; top: from the sensor's up (-y) side; orbit:DEG: the sensor's view "
                        "turned DEG degrees about its y axis through the cloud's centre")
        ->check(CLI::Validator(
            [](std::string& text) {
                try {
                    parse_render_view(text);
                    return std::string();
                } catch (const Error& error) {
                    return error.reason();
                }
            },
            "camera|top|orbit:DEG"))
        ->capture_default_str();
    command->add_option("--size", options->size,
                        "Image size (default: the cloud's grid when organized, else 640x480); pixels stay square and "
                        "the whole view stays in the picture")
        ->type_name("WxH");
    // A disc as large as the scene would make every ray test every point: a hang, not a picture.
    command->add_option("--point-radius", options->point_radius,
                        "Disc radius in metres, up to 0.1 (default: 0.8 of each point's spacing)")
        ->type_name("METRES")
        ->check(CLI::Validator(
            [](std::string& text) {
                const float value = std::strtof(text.c_str(), nullptr);
                return std::isfinite(value) && value >= 0.0f && value <= 0.1f ? std::string()
                                                                              : "must be a number in 0..0.1 (metres)";
            },
            "0..0.1"));
    command->add_option("-o,--output", options->output, "Image to write (.png)")->type_name("OUT.png")->required();
    command->callback([options, &global] { run_render(*options, global); });
}

}  // namespace mfpc::cli
