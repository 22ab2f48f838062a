#include <filesystem>
#include <iostream>
#include <string>

#include "cli_commands.hpp"
#include "mfpc/simulation/demo.hpp"

namespace mfpc::cli {
namespace {

struct DemoOptions {
    DemoParams scene;
    std::string output = "out/demo";
};

void run_demo_command(const DemoOptions& options, const GlobalOptions& global)
{
    if (!is_builtin_object(options.scene.object))
        throw CLI::ValidationError("--object", "'" + options.scene.object + "' is not a built-in object");
    // The demo's progress goes to stderr, so stdout keeps only the table (and --json - stays clean).
    auto progress = [&](const std::string& step) {
        if (!global.quiet) std::cerr << "demo: " << step << '\n';
    };
    DemoRun run = run_demo(options.scene, options.output, progress);
    progress("rendering");
    render_demo(run);
    if (print_table(global)) std::cout << to_table(run);
    write_json(global, to_json(run));
}

}  // namespace

void add_demo_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<DemoOptions>();
    CLI::App* command = app.add_subcommand(
        "demo", "No input needed: synthesize a tabletop scene, recognize its instances with and without "
                "multifoveation, print the comparison and render a picture");
    command->footer("Writes the synthetic dataset (as `mfpc synth`) and demo.png into DIR.");
    command->add_option("-o,--output", options->output, "Output directory")->type_name("DIR")->capture_default_str();
    command->add_option("--seed", options->scene.seed, "Seed of the scene")->capture_default_str();
    command->add_option("--objects", options->scene.objects, "Instances to find")->check(CLI::Range(1, 20))->capture_default_str();
    command->add_option("--distractors", options->scene.distractors, "Other objects")->check(CLI::Range(0, 20))->capture_default_str();
    command->add_option("--object", options->scene.object, "Built-in object to find: carton, bottle, mug, box, jug")
        ->capture_default_str();
    command->callback([options, &global] { run_demo_command(*options, global); });
}

}  // namespace mfpc::cli
