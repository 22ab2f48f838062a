#pragma once

#include <CLI/CLI.hpp>

#include "cli_common.hpp"

namespace mfpc::cli {

// Each adds its subcommand to the app; the subcommand's callback does the work and throws
// mfpc::Error on failure.
void add_info_command(CLI::App& app, const GlobalOptions& global);
void add_foveate_command(CLI::App& app, const GlobalOptions& global);
void add_model_command(CLI::App& app, const GlobalOptions& global);
void add_recognize_command(CLI::App& app, const GlobalOptions& global);
void add_render_command(CLI::App& app, const GlobalOptions& global);
void add_synth_command(CLI::App& app, const GlobalOptions& global);
void add_demo_command(CLI::App& app, const GlobalOptions& global);
void add_experiment_command(CLI::App& app, const GlobalOptions& global);
void add_evaluate_command(CLI::App& app, const GlobalOptions& global);
void add_synth_set_command(CLI::App& app, const GlobalOptions& global);
void add_batch_command(CLI::App& app, const GlobalOptions& global);
void add_scaling_command(CLI::App& app, const GlobalOptions& global);

}  // namespace mfpc::cli
