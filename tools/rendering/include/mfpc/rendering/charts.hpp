#pragma once

#include <filesystem>
#include <string>

namespace mfpc {

/// Throws mfpc::Error, saying how to install it, when gnuplot is not on the PATH: checked before
/// an experiment's runs, so a missing gnuplot is told at once, not after minutes of work.
void require_gnuplot();

/// Draws the paper's Figures 11 and 12 (one metric each, bars per strategy; the time chart with
/// the 95% intervals as error bars) with gnuplot into `directory`: fig11a_points.png ..
/// fig12d_time.png, from the chart data (mfpc::to_chart_data of an experiment report) written
/// there as charts.dat, with the script charts.gnuplot and gnuplot's messages in charts.log.
/// gnuplot runs in `directory` and the script names only these fixed file names, so the
/// directory's own name (any characters) never enters the script.
/// @param directory an existing folder
/// @param chart_data the data file's text
/// @throws mfpc::Error when a file cannot be written or gnuplot fails or cannot be started
void write_experiment_charts(const std::filesystem::path& directory, const std::string& chart_data);

}  // namespace mfpc
