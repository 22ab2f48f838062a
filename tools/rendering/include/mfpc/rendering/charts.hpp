#pragma once

/// @file
/// @brief The experiment's charts (the paper's Figures 11 and 12), drawn with gnuplot.

#include <filesystem>
#include <string>

namespace mfpc {

/// @brief Checks that gnuplot is on the PATH: checked before an experiment's runs, so a missing
/// gnuplot is told at once, not after minutes of work.
/// @throws mfpc::Error when gnuplot is not on the PATH, saying how to install it.
void require_gnuplot();

/// @brief Draws the paper's Figures 11 and 12 (one metric each, bars per strategy; the time chart
/// with the 95% intervals as error bars) with gnuplot into `directory`.
///
/// The charts are fig11a_points.png .. fig12d_time.png, from the chart data (mfpc::to_chart_data of
/// an experiment report) written there as charts.dat, with the script charts.gnuplot and
/// gnuplot's messages in charts.log. gnuplot runs in `directory` and the script names only these
/// fixed file names, so the directory's own name (any characters) never enters the script.
/// @param directory An existing folder.
/// @param chart_data The data file's text.
/// @throws mfpc::Error when a file cannot be written or gnuplot fails or cannot be started.
void write_experiment_charts(const std::filesystem::path& directory, const std::string& chart_data);

/// Draws a scaling study's charts with gnuplot into `directory` from its scaling.csv there (as
/// mfpc::to_csv of the study writes it): scaling_throughput.png (scenes per second against threads),
/// scaling_speedup.png (with the ideal line) and scaling_efficiency.png (end to end and per stage;
/// placement only when some row places, its efficiency being 0 on every row otherwise).
/// @param directory the folder holding scaling.csv
/// @throws mfpc::Error when the script cannot be written or gnuplot fails or cannot be started
void write_scaling_charts(const std::filesystem::path& directory);

}  // namespace mfpc
