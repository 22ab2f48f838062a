#include <filesystem>
#include <iostream>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/simulation/mesh.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"

namespace mfpc::cli {
namespace {

struct SynthOptions {
    ComposeParams compose;
    SensorParams sensor;
    std::string resolution = "640x480";
    std::string object = "carton";
    std::string distractor_objects;  // comma-separated; empty: the other built-ins
    std::string up = "-y";
    float model_spacing = 0.002f;
    std::string output;
};

Eigen::Vector3f parse_axis(const std::string& text)
{
    const bool negative = !text.empty() && text[0] == '-';
    const std::string axis = text.substr(!text.empty() && (text[0] == '-' || text[0] == '+') ? 1 : 0);
    const float sign = negative ? -1.0f : 1.0f;
    if (axis == "x") return Eigen::Vector3f(sign, 0, 0);
    if (axis == "y") return Eigen::Vector3f(0, sign, 0);
    if (axis == "z") return Eigen::Vector3f(0, 0, sign);
    throw CLI::ValidationError("--up", "'" + text + "' is not one of x, -x, y, -y, z, -z");
}

void run_synth(SynthOptions options, const GlobalOptions& global)
{
    std::tie(options.sensor.width, options.sensor.height) = parse_size(options.resolution, "--resolution");
    const Eigen::Vector3f up = parse_axis(options.up);
    check_sensor(options.sensor);
    check_model_spacing(options.model_spacing);
    prepare_output_directory(options.output);

    Stopwatch clock;
    std::vector<SceneShape> shapes;
    shapes.push_back(load_shape(options.object, up));
    std::vector<std::string> distractors = split_list(options.distractor_objects);
    if (options.distractor_objects.empty()) {
        for (std::string_view name : builtin_object_names())
            if (name != shapes[0].name) distractors.emplace_back(name);
    }
    if (options.compose.distractors > 0) {
        if (distractors.empty()) throw CLI::ValidationError("--distractor-objects", "names no object");
        for (const std::string& name : distractors) shapes.push_back(load_shape(name, up));
    }
    const double load_ms = clock.lap_ms();
    const SyntheticDataset dataset = make_synthetic_dataset(std::move(shapes), options.compose, options.sensor,
                                                            options.model_spacing);
    const double make_ms = clock.lap_ms();
    write_synthetic_dataset(options.output, dataset);
    const double write_ms = clock.lap_ms();

    const SyntheticScene& scene = dataset.scene;
    const std::size_t pixels = std::size_t(options.sensor.width) * options.sensor.height;
    nlohmann::ordered_json objects = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
        objects.push_back({{"label", label_first_object + i},
                           {"shape", scene.shapes[scene.objects[i].shape].name},
                           {"distractor", scene.objects[i].distractor},
                           {"visible_points", dataset.scan.visible_points[i]}});
    }
    if (print_table(global)) {
        std::vector<std::pair<std::string, std::string>> rows = {
            {"output", options.output},
            {"seed", std::to_string(options.compose.seed)},
            {"resolution", options.resolution + " (" + group_digits(pixels) + " rays)"},
            {"scene points", group_digits(dataset.scan.cloud.size())},
        };
        for (std::size_t i = 0; i < scene.objects.size(); ++i) {
            rows.push_back({"label " + std::to_string(label_first_object + i),
                            scene.shapes[scene.objects[i].shape].name +
                                (scene.objects[i].distractor ? " (distractor)" : " (instance)") + ", " +
                                group_digits(dataset.scan.visible_points[i]) + " points visible"});
        }
        rows.push_back({"time (ms)", "shapes " + format_fixed(load_ms, 1) + "  compose+scan+models " +
                                         format_fixed(make_ms, 1) + "  write " + format_fixed(write_ms, 1)});
        print_rows(rows);
    }
    write_json(global, {{"output", options.output},
                        {"seed", options.compose.seed},
                        {"width", options.sensor.width},
                        {"height", options.sensor.height},
                        {"points", dataset.scan.cloud.size()},
                        {"objects", objects},
                        {"timings_ms", {{"shapes", load_ms}, {"make", make_ms}, {"write", write_ms}}}});
}

}  // namespace

void add_synth_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<SynthOptions>();
    CLI::App* command = app.add_subcommand(
        "synth", "Synthesize a tabletop scene with ground truth: a virtual Kinect-like scan (Embree ray casting)");
    command->footer(
        "Writes into DIR: scene.pcd (organized, camera frame), scene.gt.json (shared ground-truth format),\n"
        "labels.png (16-bit label per pixel: 0 none, 1 table, 2+i object i), scene.json (everything),\n"
        "fovea.json (one foveated structure per instance), one model cloud <shape>.pcd per shape and\n"
        "<object>.mfpcm, the object's model cache described from 16 views, for `mfpc recognize`.\n"
        "The same seed gives the same bytes on any thread count.");
    auto& settings = *options;
    command->add_option("--seed", settings.compose.seed, "Seed of the placement, the camera and the sensor noise")
        ->capture_default_str();
    command->add_option("--objects", settings.compose.objects, "Instances of the object to recognise")
        ->check(CLI::Range(0, 1000))
        ->capture_default_str();
    command->add_option("--distractors", settings.compose.distractors, "Other objects among them")
        ->check(CLI::Range(0, 1000))
        ->capture_default_str();
    command->add_option("--resolution", settings.resolution, "Sensor image size WIDTHxHEIGHT (up to 16384x16384)")
        ->capture_default_str();
    command->add_option("--object", settings.object,
                        "The object: carton, bottle, mug, box, jug, or a mesh (.ply, .obj) or cloud (.pcd) file")
        ->capture_default_str();
    command->add_option("--distractor-objects", settings.distractor_objects,
                        "Comma-separated distractor shapes (default: the built-ins other than --object)");
    command->add_option("--up", settings.up, "Up axis of a .pcd object in its own frame: x, -x, y, -y, z, -z")
        ->capture_default_str();
    command->add_option("--focal", settings.sensor.focal_length,
                        "Focal length in pixels (0: 525 scaled by width/640; a field of view of 170 degrees at most)")
        ->capture_default_str();
    command->add_option("--noise", settings.sensor.noise_at_1m, "Depth noise sigma at 1 m in metres, growing with z^2 (0: none)")
        ->capture_default_str();
    command->add_option("--subpixel", settings.sensor.disparity_subpixel, "Disparity quantization steps per pixel (0: none)")
        ->capture_default_str();
    command->add_option("--max-incidence", settings.sensor.max_incidence_deg,
                        "No return beyond this angle between ray and surface normal (degrees)")
        ->capture_default_str();
    command->add_option("--min-range", settings.sensor.min_range, "Nearest depth with a return (metres)")->capture_default_str();
    command->add_option("--max-range", settings.sensor.max_range, "Farthest depth with a return (metres)")->capture_default_str();
    command->add_option("--model-spacing", settings.model_spacing, "Point spacing of the mesh model clouds, 0.0005..0.01 (metres)")
        ->capture_default_str();
    command->add_option("-o,--output", settings.output, "Output directory (created if missing)")->required()->type_name("DIR");
    command->callback([options, &global] { run_synth(*options, global); });
}

}  // namespace mfpc::cli
