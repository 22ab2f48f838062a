#include <filesystem>
#include <iostream>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/simulation/mesh.hpp"
#include "mfpc/simulation/synthetic_scene.hpp"
#include "mfpc/simulation/synthetic_sequence.hpp"

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
    SequenceParams sequence{.frames = 0};  // frames 0: a single scene (no --sequence)
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

// The object to recognise, then the distractor shapes.
std::vector<SceneShape> load_synth_shapes(const SynthOptions& options, const Eigen::Vector3f& up)
{
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
    return shapes;
}

void run_sequence(const SynthOptions& options, std::vector<SceneShape> shapes, double load_ms, Stopwatch& clock,
                  const GlobalOptions& global)
{
    Progress bar;
    write_synthetic_sequence(options.output, std::move(shapes), options.compose, options.sensor, options.sequence,
                             options.model_spacing, RecognitionParams{}.model,
                             [&](std::size_t done, std::size_t total) {
                                 if (!global.quiet) bar.draw(done, total, "models and frames");
                             });
    const double sequence_ms = clock.lap_ms();
    const std::filesystem::path output(options.output);
    const std::string manifest = (output / "dataset.json").string();
    const std::string frame_list = (output / "frames.txt").string();
    const double step = sequence_heading_step_deg(options.sequence);
    if (print_table(global)) {
        print_rows({{"output", options.output},
                    {"seed", std::to_string(options.compose.seed)},
                    {"resolution", options.resolution},
                    {"frames", std::to_string(options.sequence.frames) + ", the heading turning " +
                                   format_fixed(options.sequence.arc_deg, 1) + " degrees in steps of " +
                                   format_fixed(step, 3)},
                    {"manifest", manifest},
                    {"frame list", frame_list},
                    {"time (ms)", "shapes " + format_fixed(load_ms, 1) + "  models+frames " + format_fixed(sequence_ms, 1) +
                                      " (" + format_fixed(sequence_ms / options.sequence.frames, 1) + " a frame)"}});
    }
    write_json(global, {{"output", options.output},
                        {"seed", options.compose.seed},
                        {"width", options.sensor.width},
                        {"height", options.sensor.height},
                        {"frames", options.sequence.frames},
                        {"arc_deg", options.sequence.arc_deg},
                        {"heading_step_deg", step},
                        {"manifest", manifest},
                        {"frame_list", frame_list},
                        {"timings_ms", {{"shapes", load_ms}, {"sequence", sequence_ms}}}});
}

void run_synth(SynthOptions options, const GlobalOptions& global)
{
    std::tie(options.sensor.width, options.sensor.height) = parse_size(options.resolution, "--resolution");
    const Eigen::Vector3f up = parse_axis(options.up);
    const bool sequence = options.sequence.frames > 0;
    if (sequence) {
        try {
            check_sequence_params(options.sequence);
        } catch (const Error& error) {
            throw CLI::ValidationError(error.where() == "arc_deg" ? "--arc" : "--sequence", error.reason());
        }
    }
    check_sensor(options.sensor);
    check_model_spacing(options.model_spacing);
    prepare_output_directory(options.output);

    Stopwatch clock;
    std::vector<SceneShape> shapes = load_synth_shapes(options, up);
    const double load_ms = clock.lap_ms();
    if (sequence) return run_sequence(options, std::move(shapes), load_ms, clock, global);
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
        "With --sequence N: the objects composed once, then N frames of a camera orbiting their centre\n"
        "(same distance and elevation, the heading turning --arc degrees from the first frame to the last,\n"
        "counter-clockwise seen from above): DIR/frame_NNN/ per frame with its scene.pcd, scene.gt.json (in\n"
        "that frame's camera frame, with visible fractions; model ../<shape>.pcd), labels.png, scene.json and\n"
        "fovea.json; the model clouds and the model cache once in DIR; DIR/dataset.json (for `mfpc evaluate\n"
        "--dataset`) and DIR/frames.txt (for `mfpc batch --scenes`).\n"
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
    CLI::Option* frames =
        command
            ->add_option("--sequence", settings.sequence.frames,
                         "Write a sequence of N frames (2..10000) of a camera orbiting the objects, not one scene")
            ->check(CLI::Range(2, 10000))
            ->type_name("N");
    command
        ->add_option("--arc", settings.sequence.arc_deg,
                     "With --sequence: degrees the camera's heading turns from the first frame to the last, in (0, 360]")
        ->needs(frames)
        ->type_name("DEG")
        ->capture_default_str();
    command->add_option("-o,--output", settings.output, "Output directory (created if missing)")->required()->type_name("DIR");
    command->callback([options, &global] { run_synth(*options, global); });
}

}  // namespace mfpc::cli
