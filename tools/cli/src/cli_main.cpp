// The mfpc command line: parses, calls the library, prints. Errors from the library arrive as
// mfpc::Error and leave as one line "mfpc: <where>: <reason>" with exit code 1; usage errors exit 2.

#include <exception>
#include <iostream>
#include <memory>
#include <new>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include <CLI/CLI.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>

#include "cli_commands.hpp"
#include "mfpc/core/error.hpp"

namespace {

// An option or argument given as an empty string ("-o ''", often an unset shell variable) is a
// usage error: the commands read an empty path as "not given" and would silently skip the output.
void reject_empty_values(const CLI::App& app)
{
    for (const CLI::Option* option : app.get_options()) {
        if (option->count() == 0 || option->get_expected_min() == 0) continue;  // absent, or a flag
        for (const std::string& value : option->results()) {
            if (value.empty()) throw CLI::ValidationError(option->get_name(), "is empty");
        }
    }
    for (const CLI::App* command : app.get_subcommands()) reject_empty_values(*command);
}

// Freed memory stays with the process for the next scene. glibc hands each block of 128 KiB and up
// to mmap and gives the top of the heap back when 128 KiB of it are free (doubling both as blocks
// are freed), so each scene's neighbour lists, descriptors and buffers came as fresh pages, faulted
// in and zeroed by the kernel again: a fifth of a one-thread batch of Kinect scenes (12 milk_pair
// scenes: 4.3 s, 3.3 s with this) for the same peak memory, which the first scene already reaches.
// The mmap threshold's largest value keeps clouds of more than 32 MiB off the heap. Each arena
// keeps up to 64 MiB of free top, about what one 640x480 scene's buffers take: 512 MiB was no
// faster (12 milk_pair scenes, 40 synthetic Kinect scenes) and would let more stay.
void keep_freed_memory()
{
#if defined(__GLIBC__)
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 64 << 20);
#endif
}

}  // namespace

int main(int argc, char** argv)
{
    using namespace mfpc::cli;
    keep_freed_memory();

    CLI::App app{"mfpc: multifoveated point clouds and 3D object recognition\n"
                 "(Oliveira et al., \"Efficient 3D Objects Recognition Using Multifoveated Point Clouds\", "
                 "Sensors 2018)",
                 "mfpc"};
    app.set_version_flag("--version", std::string("mfpc ") + MFPC_VERSION);
    app.require_subcommand(1);
    app.fallthrough();

    GlobalOptions global;
    app.add_option("--threads", global.threads, "Worker threads (default: all cores)")
        ->check(CLI::Range(1, 4096));
    app.add_option("--json", global.json_path, "Also write the result as JSON to PATH ('-' for stdout)")
        ->type_name("PATH");
    app.add_flag("-q,--quiet", global.quiet, "Print no table (errors and warnings still go to stderr)");

    add_info_command(app, global);
    add_foveate_command(app, global);
    add_model_command(app, global);
    add_recognize_command(app, global);
    add_render_command(app, global);
    add_synth_command(app, global);
    add_synth_set_command(app, global);
    add_demo_command(app, global);
    add_experiment_command(app, global);
    add_evaluate_command(app, global);
    add_batch_command(app, global);
    add_scaling_command(app, global);

    // The thread limit must be in force before any command runs, so it is set from a pre-parse
    // callback: after the options are read, before the subcommand callbacks.
    std::unique_ptr<tbb::global_control> threads;
    app.parse_complete_callback([&] {
        reject_empty_values(app);
        const int count = global.threads > 0 ? global.threads : tbb::info::default_concurrency();
        threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                        std::size_t(count));
    });

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "mfpc: " << e.what() << " (see 'mfpc --help')\n";
        return 2;
    } catch (const mfpc::Error& e) {
        std::cerr << "mfpc: " << e.what() << '\n';
        return 1;
    } catch (const std::bad_alloc&) {
        std::cerr << "mfpc: out of memory\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "mfpc: internal error: " << e.what() << '\n';
        return 1;
    }
    return exit_status();
}
