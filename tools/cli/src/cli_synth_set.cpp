#include <iostream>
#include <memory>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/simulation/synthetic_set.hpp"

namespace mfpc::cli {
namespace {

struct SynthSetOptions {
    SyntheticSetParams set;
    std::string presets = "kinect,stereo,hd720";
    std::string shapes;
    std::string params;
    std::string output;
};

void run_synth_set(SynthSetOptions options, const GlobalOptions& global)
{
    options.set.presets = split_list(options.presets);
    if (options.set.presets.empty()) throw CLI::ValidationError("--presets", "names no preset");
    for (const std::string& preset : options.set.presets) sensor_preset(preset);  // an unknown one fails before any work
    options.set.shapes = split_list(options.shapes);
    if (!options.params.empty()) options.set.features = read_recognition_params(options.params).model;
    if (!(options.set.camera_distance_min > 0 && options.set.camera_distance_min <= options.set.camera_distance_max))
        throw CLI::ValidationError("--distance-min", "must be positive and at most --distance-max");
    Stopwatch clock;
    Progress bar;
    write_synthetic_set(options.output, options.set, [&](std::size_t done, std::size_t total) {
        if (!global.quiet) bar.draw(done, total, "scenes and models");
    });
    const double ms = clock.lap_ms();
    const std::string manifest = (std::filesystem::path(options.output) / "dataset.json").string();
    if (print_table(global)) {
        print_rows({{"output", options.output},
                    {"presets", options.presets},
                    {"scenes", std::to_string(options.set.scenes) + " per preset"},
                    {"manifest", manifest},
                    {"time (ms)", format_fixed(ms, 0)}});
    }
    write_json(global, {{"output", options.output},
                        {"presets", options.set.presets},
                        {"scenes_per_preset", options.set.scenes},
                        {"manifest", manifest},
                        {"timings_ms", {{"total", ms}}}});
}

}  // namespace

void add_synth_set_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<SynthSetOptions>();
    CLI::App* command = app.add_subcommand(
        "synth-set", "Synthesize a benchmark set for `mfpc evaluate`: scenes per sensor preset, models described once");
    command->footer(
        "Writes into DIR: models/<preset>_<shape>.mfpcm (each object described from 16 views 1 m away, with the\n"
        "preset's noise), one directory <preset>_<NNN> per scene as `mfpc synth` writes it (its ground truth\n"
        "gives each instance's visible fraction), and dataset.json, the manifest. Scene k of a preset has\n"
        "seed FIRST+k and recognises shape k of --shapes (in turn).\n"
        "Presets: kinect (640x480, fx 525, 1.5 mm at 1 m), stereo (640x480, fx 960, 2 mm at 1 m),\n"
        "hd720 (1280x720, fx 910, 1 mm at 1 m); depth noise grows with z^2.");
    auto& s = options->set;
    command->add_option("--presets", options->presets, "Comma-separated sensor presets: kinect, stereo, hd720")
        ->capture_default_str();
    command->add_option("--scenes", s.scenes, "Scenes per preset")->check(CLI::Range(1, 100000))->capture_default_str();
    command->add_option("--first-seed", s.first_seed, "Seed of the first scene")->capture_default_str();
    command->add_option("--objects", s.objects, "Instances of the scene's object to recognise")
        ->check(CLI::Range(1, 100))
        ->capture_default_str();
    command->add_option("--distractors", s.distractors, "Other built-in objects among them")
        ->check(CLI::Range(0, 100))
        ->capture_default_str();
    command->add_option("--shapes", options->shapes,
                        "Comma-separated objects to recognise, in turn (default: every built-in: carton, bottle, "
                        "mug, box, jug)");
    command->add_option("--distance-min", s.camera_distance_min, "Nearest camera distance to the objects' centre (m)")
        ->capture_default_str();
    command->add_option("--distance-max", s.camera_distance_max, "Farthest camera distance to the objects' centre (m)")
        ->capture_default_str();
    command->add_option("-p,--params", options->params,
                        "Recognition parameters whose \"model\" block describes the models (default: the built-in set)")
        ->type_name("PARAMS.json");
    command->add_option("-o,--output", options->output, "Output directory (created if missing)")
        ->required()
        ->type_name("DIR");
    command->callback([options, &global] { run_synth_set(*options, global); });
}

}  // namespace mfpc::cli
