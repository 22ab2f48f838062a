#pragma once

/// @file
/// @brief The foveation config of a multifoveated cloud (its structures and downsampling), its JSON
/// form, and the names of the foveation modes.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "mfpc/core/foveated_structure.hpp"

namespace mfpc {

/// @brief How a cloud is foveated.
enum class FoveationMode {
    none,    ///< No foveation: the cloud passes unchanged.
    single,  ///< One structure (the FPC of Gomes et al. 2013).
    raw,     ///< Each structure on its own, results concatenated (overlaps appear more than once).
    mfpc,    ///< Redundancy treatment (paper Eq. 6, Algorithm 1): each point once, at its densest level.
};

/// @brief How each level region is downsampled at its density d_k.
enum class Downsample {
    voxel,    ///< Centroid of the points in each voxel of size d_k (as PCL's VoxelGrid).
    uniform,  ///< The original point nearest each voxel centre (as PCL's UniformSampling).
};

/// @brief What to do with a fovea that pokes out of its outer box.
enum class FoveaPolicy {
    clamp,   ///< Clamp F to ±(S_0 - S_m)/2 and report a warning (as the original FPC does).
    strict,  ///< Reject the config.
};

/// @brief Structures of one multifoveated cloud.
///
/// m lives in each structure (a structure's boxes need it) and nowhere else; the paper's
/// redundancy treatment (Section 4.2) compares levels across structures, so the reader and the
/// kernel require them to share it.
struct FoveationConfig {
    Downsample downsample = Downsample::voxel;  ///< How every level region is downsampled.
    std::vector<FoveatedStructure> structures;  ///< The structures, in config order (their index is RegionLabel::structure).

    /// @brief m.
    /// @return The first structure's levels (0 without structures).
    int levels() const { return structures.empty() ? 0 : structures.front().levels; }
};

/// @brief Parses a foveation config (JSON; keys documented in the README):
///
///     { "levels": 3, "downsample": "voxel",
///       "structures": [ { "outer_min": [x,y,z], "outer_size": [x,y,z], "fovea_size": [x,y,z],
///                         "fovea_center": [x,y,z] | "fovea_offset": [x,y,z],
///                         "density": [d0, dm], "keypoint_radius": [r0, rm], "levels": m? } ] }
///
/// A structure may also carry a "name". Out-of-range foveae are clamped (each clamp appends a line
/// to *warnings) or rejected, per policy; a fovea that lands a few float roundings beyond its outer
/// box (one written flush with it) is put on the face without a warning.
/// @param json_text The JSON text.
/// @param source Names the text in errors (usually the file name).
/// @param policy What to do with a fovea outside its outer box.
/// @param warnings When given, receives one line per clamped fovea.
/// @return The config, its structures in the order given.
/// @throws mfpc::Error whose where() is "source: key", e.g. "fovea.json: structures[1].outer_size",
/// for every bad config: invalid JSON (or a duplicate key), a missing or unknown key, a wrong type
/// or length, a non-finite number, a zero or negative size, an outer box reaching past the float
/// range, a fovea bigger than its outer box, both or neither of fovea_center and fovea_offset, a
/// negative density, a keypoint radius that is not positive, levels < 1 or above max_levels,
/// structures with different levels, no structures (or more than RegionLabel can number), and,
/// under FoveaPolicy::strict, a fovea outside its outer box.
FoveationConfig parse_foveation_config(std::string_view json_text, const std::string& source,
                                       FoveaPolicy policy = FoveaPolicy::clamp,
                                       std::vector<std::string>* warnings = nullptr);
/// @brief Reads a foveation config file, as parse_foveation_config with the path as its source.
/// @param path The JSON file.
/// @param policy What to do with a fovea outside its outer box.
/// @param warnings When given, receives one line per clamped fovea.
/// @return The config.
/// @throws mfpc::Error naming the path when the file cannot be read (missing, a directory, not a
/// regular file, unreadable), or as parse_foveation_config.
FoveationConfig read_foveation_config(const std::filesystem::path& path,
                                      FoveaPolicy policy = FoveaPolicy::clamp,
                                      std::vector<std::string>* warnings = nullptr);

/// @brief The JSON text of a config, in the form parse_foveation_config reads (fovea given as
/// "fovea_center", or as "fovea_offset" for an F too small to survive being added to Δ + S_0/2).
/// Numbers are written so that they read back to the same floats. A structure whose m differs
/// from the first one's is written with its own "levels", so that reading the text back reports
/// the mismatch instead of hiding it.
/// @param config The config.
/// @return Indented JSON text with a final newline.
/// @throws mfpc::Error for a non-finite number in a structure, which JSON cannot hold.
std::string to_json(const FoveationConfig& config);

/// @brief The name of a foveation mode, as parse_foveation_mode reads it.
/// @param mode The mode.
/// @return "none", "single", "raw" or "mfpc".
const char* to_string(FoveationMode mode);
/// @brief The name of a downsampling, as parse_downsample reads it.
/// @param downsample The downsampling.
/// @return "voxel" or "uniform".
const char* to_string(Downsample downsample);
/// @brief The foveation mode named by `text`.
/// @param text "none", "single", "raw" or "mfpc".
/// @param where The name of the setting, for the error.
/// @return The mode.
/// @throws mfpc::Error naming `where` for any other text.
FoveationMode parse_foveation_mode(std::string_view text, const std::string& where = "mode");
/// @brief The downsampling named by `text`.
/// @param text "voxel" or "uniform".
/// @param where The name of the setting, for the error.
/// @return The downsampling.
/// @throws mfpc::Error naming `where` for any other text.
Downsample parse_downsample(std::string_view text, const std::string& where = "downsample");

}  // namespace mfpc
