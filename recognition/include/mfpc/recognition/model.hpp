#pragma once

/// @file
/// @brief Models ready for recognition: preparing them from a cloud, and the model cache (.mfpcm).

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "mfpc/core/point_cloud.hpp"
#include "mfpc/recognition/features.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

struct ModelVerification;

/// @brief A model ready for recognition: its cloud with normals (for refinement and verification)
/// and its described keypoints, with the parameters they were computed with.
struct Model {
    std::vector<Point> points;   ///< The model cloud.
    std::vector<Point> normals;  ///< One per point, NaN where undefined.
    Features features;           ///< The described keypoints.
    FeatureParams params;        ///< The parameters they were computed with.
    std::string source;          ///< The file the model came from.
    /// Its verification prepared once for some parameters (prepare_model_verification), which
    /// recognition uses when they are the run's; without it, each run makes what it needs. Not
    /// in the cache. Shared by copies: set it again after changing the points or normals.
    std::shared_ptr<const ModelVerification> verification;
};

/// @brief Prepares the model's verification for a run's parameters once (prepare_verification), so
/// that each scene it is recognised in does not make it again: its thinned points, turns and rim
/// probes, about 10 ms of a Kinect scene's verification.
/// @param model The model; its `verification` is set.
/// @param params The run's parameters (their refine and verify blocks).
/// @throws mfpc::Error when the model's normals are not one per point.
void prepare_model_verification(Model& model, const RecognitionParams& params);

/// @brief The centroid of the model's points: where an instance's transform puts the object (its
/// translation moves the model's origin, which for a scanned view is its sensor, a metre or two
/// away).
/// @param model The model.
/// @return The mean of its points (the origin for a model without points).
Point model_centroid(const Model& model);

/// @brief Prepares a model from its cloud: normals, then keypoints and their description.
///
/// Normals are estimated (k = normal_k) and face the sensor at the origin, as for a scanned view;
/// when the cloud carries normals (a model sampled all around a mesh), they orient the estimated
/// ones. Keypoints are described at the working resolution when params.resolution > 0
/// (describe_at_resolution), else by uniform sampling of the cloud (describe_keypoints).
/// @param cloud The model cloud (exact copies of a point are described once, see distinct_points).
/// @param params The description parameters.
/// @param source The file the model came from, kept in the model and named by errors.
/// @param timings When given, the time of each step is added to it.
/// @return The model.
/// @throws mfpc::Error naming `source` for a cloud with no points or a model with fewer than 3
/// usable keypoints (require_model_keypoints), or as the normal estimation, sampling and
/// description it runs.
Model prepare_model(const PointCloud& cloud, const FeatureParams& params, const std::string& source,
                    FeatureTimings* timings = nullptr);

/// @brief Checks that a model has at least 3 usable keypoints. prepare_model calls it.
/// @param features The model's features.
/// @param params The parameters they were computed with, named in the error.
/// @param where The model, for the error.
/// @throws mfpc::Error (naming `where`) when a model has fewer than 3 usable keypoints, saying why
/// it likely has: few sampled (an object small for params.keypoint_radius), or many sampled and
/// none with a frame or descriptor (supports too sparse, or points on a line).
void require_model_keypoints(const Features& features, const FeatureParams& params, const std::string& where);

/// @brief Whether a file name is a model cache's.
/// @param path The file name.
/// @return Whether it ends in .mfpcm (the model cache, see write_model_cache).
bool is_model_cache(const std::filesystem::path& path);

/// @brief The model a command was given: a cache as it was written, or a cloud (.pcd, .ply)
/// described with `params`.
/// @param path A model cache (.mfpcm) or a cloud.
/// @param params The description parameters for a cloud, and the ones a cache is checked against.
/// @param check_cache_params Whether a cache made with other parameters is stale for this run.
/// @param params_source Where the parameters came from, named in the stale-cache error.
/// @param timings When given (and a cloud is described), the time of each step is added to it.
/// @return The model.
/// @throws mfpc::Error naming the cache and `params_source` for a stale cache (with
/// `check_cache_params`), or as read_model_cache, or read_cloud and prepare_model.
Model load_model(const std::filesystem::path& path, const FeatureParams& params, bool check_cache_params,
                 const std::string& params_source, FeatureTimings* timings = nullptr);

/// @brief Writes the model cache (.mfpcm): a versioned binary file holding all of Model, so batch
/// runs do not describe the model again.
///
/// Written to a temporary file and renamed into place, as write_cloud does.
/// @param path The cache file.
/// @param model The model.
/// @throws mfpc::Error naming the file when it cannot be created, written or renamed into place.
void write_model_cache(const std::filesystem::path& path, const Model& model);
/// @brief The bytes of the cache write_model_cache writes, for a caller that writes several
/// outputs all or none.
/// @param model The model.
/// @return The whole file.
std::string model_cache_bytes(const Model& model);
/// @brief Reads a model cache written by write_model_cache.
/// @param path The cache file.
/// @return The model as it was written.
/// @throws mfpc::Error for a file that is not a cache, a cache of another format version, or a
/// truncated or corrupt one (checked by size and checksum, then by its values: non-finite
/// coordinates or descriptors, invalid parameters, fewer than 3 keypoints, no points).
Model read_model_cache(const std::filesystem::path& path);
/// The format version of the model cache: 2 added FeatureParams::resolution.
inline constexpr std::uint32_t model_cache_version = 2;  // 2: FeatureParams::resolution

}  // namespace mfpc
