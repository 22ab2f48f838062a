#pragma once

#include <string>
#include <utility>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/kernels/foveate.hpp"

namespace mfpc {

/// What `mfpc foveate` reports of one foveation: the input, the config's shape, the points kept
/// per region and the times of each step.
struct FoveationReport {
    std::string input;                  ///< the cloud's file, or a description of a generated scene
    std::string output;                 ///< the file the foveated cloud went to ("" none)
    FoveationMode mode = FoveationMode::mfpc;
    int single_structure = 0;           ///< the structure of mode single
    Downsample downsample = Downsample::voxel;
    std::size_t structures = 0;         ///< structures in the config
    int levels = 0;                     ///< m
    std::size_t points_in = 0;          ///< points in the file (NaN ones too)
    std::size_t points_finite = 0;      ///< points with finite coordinates
    const FoveatedCloud* result = nullptr;  ///< the foveation (must be set)
    std::vector<std::pair<std::string, double>> timings_ms;  ///< steps in the order they ran
    int threads = 1;                    ///< worker threads of the run
    std::vector<std::string> warnings;  ///< warnings the run gave (clamped foveae, ...)
};

/// The report as JSON text (key names in the README, "mfpc foveate"): counts, one entry per level
/// region kept (structure, level, density, points before and after downsampling; mode single
/// lists its structure's only), the redundant points removed (mode mfpc) or repeated (mode raw).
/// @throws mfpc::Error when `report.result` is not set
std::string to_json(const FoveationReport& report);

/// The report as the text table `mfpc foveate` prints.
/// @throws mfpc::Error when `report.result` is not set
std::string to_table(const FoveationReport& report);

/// One level region's points of a foveated cloud, and the file name `mfpc foveate --regions-dir`
/// gives it ("structure1_level2.pcd").
struct RegionCloud {
    RegionLabel label;
    std::string file_name;
    PointCloud cloud;
};

/// Splits a foveated cloud into its level regions, in output order (foveate() groups its output
/// by region, so each region is one run of equal labels).
/// @throws mfpc::Error when the labels do not match the cloud's points in number
std::vector<RegionCloud> region_clouds(const FoveatedCloud& foveated);

}  // namespace mfpc
