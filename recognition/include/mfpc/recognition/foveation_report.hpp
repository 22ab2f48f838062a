#pragma once

/// @file
/// @brief The report of `mfpc foveate` (its JSON and text table), and a foveated cloud split into
/// its level regions.

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/kernels/foveate.hpp"
#include "mfpc/recognition/placement.hpp"

namespace mfpc {

/// @brief What `mfpc foveate` reports of one foveation: the input, the config's shape, the points
/// kept per region and the times of each step.
struct FoveationReport {
    std::string input;                  ///< The cloud's file, or a description of a generated scene.
    std::string output;                 ///< The file the foveated cloud went to ("" none).
    FoveationMode mode = FoveationMode::mfpc;  ///< How the cloud was foveated.
    int single_structure = 0;           ///< The structure of mode single.
    Downsample downsample = Downsample::voxel;  ///< How the regions were downsampled.
    std::size_t structures = 0;         ///< Structures in the config.
    int levels = 0;                     ///< m.
    std::size_t points_in = 0;          ///< Points in the file (NaN ones too).
    std::size_t points_finite = 0;      ///< Points with finite coordinates.
    const FoveatedCloud* result = nullptr;  ///< The foveation (must be set).
    std::vector<std::pair<std::string, double>> timings_ms;  ///< Steps in the order they ran.
    int threads = 1;                    ///< Worker threads of the run.
    std::vector<std::string> warnings;  ///< Warnings the run gave (clamped foveae, ...).
    /// The automatic placement the config came from (`--config auto`); absent otherwise.
    std::optional<PlacementResult> placement;
};

/// @brief The report as JSON text (key names in the README, "mfpc foveate"): counts, one entry per
/// level region kept (structure, level, density, points before and after downsampling; mode single
/// lists its structure's only), the redundant points removed (mode mfpc) or repeated (mode raw).
/// @param report The foveation to write.
/// @return Indented JSON text with a final newline.
/// @throws mfpc::Error when `report.result` is not set.
std::string to_json(const FoveationReport& report);

/// @brief The report as the text table `mfpc foveate` prints: the counts, one row per level region
/// (as to_json lists them) and the step times.
/// @param report The foveation to write.
/// @return Text with a final newline.
/// @throws mfpc::Error when `report.result` is not set.
std::string to_table(const FoveationReport& report);

/// @brief One level region's points of a foveated cloud, and the file name
/// `mfpc foveate --regions-dir` gives it ("structure1_level2.pcd").
struct RegionCloud {
    RegionLabel label;      ///< The region (structure, level).
    std::string file_name;  ///< `structure<l>_level<k>.pcd`, l and k the label's.
    PointCloud cloud;       ///< Its points with their attributes and source positions.
};

/// @brief Splits a foveated cloud into its level regions, in output order (foveate() groups its
/// output by region, so each region is one run of equal labels).
/// @param foveated The foveated cloud.
/// @return One entry per run of equal labels.
/// @throws mfpc::Error when the labels do not match the cloud's points in number.
std::vector<RegionCloud> region_clouds(const FoveatedCloud& foveated);

}  // namespace mfpc
