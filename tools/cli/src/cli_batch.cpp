#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "cli_commands.hpp"
#include "mfpc/batch/batch.hpp"
#include "mfpc/batch/process_group.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/model.hpp"

namespace mfpc::cli {
namespace {

struct BatchOptions {
    std::vector<std::string> models;
    std::vector<std::string> scenes;
    std::string output;
    std::string params;
    BatchFoveaOptions fovea;
    bool resume = false;
};

// Runs this process's share of the job and, under mpirun, merges the shares.
void run_share(const ProcessGroup& group, const BatchJob& job, const BatchOptions& options, const GlobalOptions& global)
{
    // Under mpirun every process runs every N-th scene into its own part; rank 0 merges the parts
    // in the scenes' order, so the output is the one a single process writes.
    const bool shared = group.size() > 1;
    if (shared && !options.resume && std::filesystem::exists(options.output))
        throw Error(options.output, "exists: pass --resume to continue that batch, or remove the file");
    BatchOutput output(shared ? part_path(options.output, group.rank()) : std::filesystem::path(options.output),
                       options.resume);
    if (shared) output.mark_done(BatchOutput::scenes_in(options.output));
    Progress bar;
    BatchSummary summary = run_batch(job, output, {group.rank(), group.size()},
                                     [&](std::size_t done, std::size_t total, const std::string& scene) {
        if (!global.quiet && group.rank() == 0) bar.draw(done, total, std::filesystem::path(scene).filename().string());
    });
    if (shared) {
        group.barrier();  // every part is complete
        if (group.rank() == 0) {
            std::vector<std::filesystem::path> parts;
            for (int rank = 0; rank < group.size(); ++rank) parts.push_back(part_path(options.output, rank));
            merge_parts(job, options.output, parts);
        }
        std::vector<std::uint64_t> counts = {summary.recognised, summary.failed};
        counts.insert(counts.end(), summary.instances.begin(), summary.instances.end());
        counts = group.sum(counts);
        summary.recognised = counts[0];
        summary.failed = counts[1];
        std::copy(counts.begin() + 2, counts.end(), summary.instances.begin());
        summary.skipped = summary.scenes - summary.recognised - summary.failed;
        summary.seconds = group.max(summary.seconds);
        summary.peak_memory_bytes = std::size_t(group.max(double(summary.peak_memory_bytes)));
    }
    if (group.rank() == 0) {
        if (print_table(global)) std::cout << to_table(summary);
        write_json(global, to_json(summary));
    }
    if (summary.failed > 0) {
        if (group.rank() == 0)
            warn(std::to_string(summary.failed) + " of " + std::to_string(summary.recognised + summary.failed) +
                 " scenes failed: their error records are in " + options.output);
        set_exit_status(3);
    }
}

void run_batch_command(const BatchOptions& options, const GlobalOptions& global)
{
    BatchJob job;
    FoveationConfig fovea;
    apply_batch_fovea_options(options.fovea, job, fovea);
    job.scenes = list_scenes(options.scenes);
    job.params = load_params(options.params);
    const ProcessGroup group;
    try {
        if (group.size() > 1 && is_sequence(job))
            throw Error("--sequence", "the frames are one chain, each placed from the instances of the one before: "
                                      "they cannot be shared between the " + std::to_string(group.size()) +
                                      " processes of mpirun (run the sequence without mpirun)");
        job.models = load_batch_models(options.models, job.params, options.params);
        run_share(group, job, options, global);
    } catch (const std::exception& e) {
        // Under mpirun the launch ends (MPI_Abort) as this unwinds, before main could say why.
        if (group.launched()) std::cerr << "mfpc: rank " << group.rank() << ": " << e.what() << '\n';
        throw;
    }
}

}  // namespace

void add_batch_command(CLI::App& app, const GlobalOptions& global)
{
    auto options = std::make_shared<BatchOptions>();
    CLI::App* command = app.add_subcommand(
        "batch", "Recognise several models in many scenes: each scene described once, a bounded parallel pipeline, "
                 "one JSON line per scene");
    command->add_option("--model", options->models,
                        "Model cloud (.pcd, .ply) or cache (.mfpcm); repeat for several models")
        ->type_name("MODEL")
        ->required();
    command->add_option("--scenes", options->scenes,
                        "A folder (its .pcd and .ply files), a list file (one path a line), a cloud, or a glob "
                        "('dir/*.pcd'); repeat to add more")
        ->type_name("DIR|LIST|GLOB")
        ->required();
    command->add_option("-o,--output", options->output, "The records, one JSON line per scene (appended as they finish)")
        ->type_name("OUT.jsonl")
        ->required();
    command->add_option("-p,--params", options->params, "Recognition parameters (JSON; keys in the README)")
        ->type_name("PARAMS.json");
    add_batch_fovea_options(command, options->fovea);
    command->add_flag("--resume", options->resume,
                      "Continue OUT: skip the scenes it already has (a torn last line is cut and its scene run "
                      "again); a sequence's track is rebuilt from the records of the frames done");
    command->footer("Records are in the order of the scenes. Under `mpirun -np N` the processes share the scenes\n"
                    "(every N-th each, into OUT.part-RANK) and rank 0 merges them into OUT in the scenes' order;\n"
                    "a --sequence runs in one process, its frames one after another. With --fovea auto each\n"
                    "record has a \"placement\" object (strategy, structures, counts, ms, fallback). Exit status:\n"
                    "0 when every scene was recognised, 3 when some failed (each has an error record and the\n"
                    "others went on), 1 or 2 for a batch that could not start.");
    command->callback([options, &global] { run_batch_command(*options, global); });
}

}  // namespace mfpc::cli
