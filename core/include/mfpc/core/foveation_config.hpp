#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "mfpc/core/foveated_structure.hpp"

namespace mfpc {

enum class FoveationMode {
    none,    // no foveation: the cloud passes unchanged
    single,  // one structure (the FPC of Gomes et al. 2013)
    raw,     // each structure on its own, results concatenated (overlaps appear more than once)
    mfpc,    // redundancy treatment (paper Eq. 6, Algorithm 1): each point once, at its densest level
};

enum class Downsample {
    voxel,    // centroid of the points in each voxel of size d_k (as PCL's VoxelGrid)
    uniform,  // the original point nearest each voxel centre (as PCL's UniformSampling)
};

// What to do with a fovea that pokes out of its outer box.
enum class FoveaPolicy {
    clamp,   // clamp F to ±(S_0 - S_m)/2 and report a warning (as the original FPC does)
    strict,  // reject the config
};

// Structures of one multifoveated cloud. m lives in each structure (a structure's boxes need it)
// and nowhere else; the paper's redundancy treatment (Section 4.2) compares levels across
// structures, so the reader and the kernel require them to share it.
struct FoveationConfig {
    Downsample downsample = Downsample::voxel;
    std::vector<FoveatedStructure> structures;

    // m: the first structure's levels (0 without structures).
    int levels() const { return structures.empty() ? 0 : structures.front().levels; }
};

// Parses a foveation config (JSON; keys documented in the README):
//   { "levels": 3, "downsample": "voxel",
//     "structures": [ { "outer_min": [x,y,z], "outer_size": [x,y,z], "fovea_size": [x,y,z],
//                       "fovea_center": [x,y,z] | "fovea_offset": [x,y,z],
//                       "density": [d0, dm], "keypoint_radius": [r0, rm], "levels": m? } ] }
// `source` names the text in errors (usually the file name). Every bad config (invalid JSON, a
// missing or unknown key, a wrong type or length, a non-finite number, a zero or negative size, a
// fovea bigger than its outer box, levels < 1, structures with different levels, no structures)
// throws mfpc::Error whose where() is "source: key", e.g. "fovea.json: structures[1].outer_size".
// Out-of-range foveae are clamped (each clamp appends a line to *warnings) or rejected, per policy.
FoveationConfig parse_foveation_config(std::string_view json_text, const std::string& source,
                                       FoveaPolicy policy = FoveaPolicy::clamp,
                                       std::vector<std::string>* warnings = nullptr);
FoveationConfig read_foveation_config(const std::filesystem::path& path,
                                      FoveaPolicy policy = FoveaPolicy::clamp,
                                      std::vector<std::string>* warnings = nullptr);

// The JSON text of a config, in the form parse_foveation_config reads (fovea given as "fovea_center").
std::string to_json(const FoveationConfig& config);

const char* to_string(FoveationMode mode);
const char* to_string(Downsample downsample);
// Parse "none|single|raw|mfpc" and "voxel|uniform"; throw mfpc::Error naming `where` otherwise.
FoveationMode parse_foveation_mode(std::string_view text, const std::string& where = "mode");
Downsample parse_downsample(std::string_view text, const std::string& where = "downsample");

}  // namespace mfpc
