#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "mfpc/core/point_cloud.hpp"
#include "mfpc/recognition/features.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

// A model ready for recognition: its cloud with normals (for refinement and verification) and its
// described keypoints, with the parameters they were computed with.
struct Model {
    std::vector<Point> points;
    std::vector<Point> normals;  // one per point, NaN where undefined
    Features features;
    FeatureParams params;
    std::string source;          // the file the model came from
};

// The centroid of the model's points: where an instance's transform puts the object (its
// translation moves the model's origin, which for a scanned view is its sensor, a metre or two away).
Point model_centroid(const Model& model);

// Normals are estimated (k = normal_k) and face the sensor at the origin, as for a scanned view;
// when the cloud carries normals (a model sampled all around a mesh), they orient the estimated ones.
Model prepare_model(const PointCloud& cloud, const FeatureParams& params, const std::string& source,
                    FeatureTimings* timings = nullptr);

// Throws mfpc::Error (naming `where`) when a model has fewer than 3 usable keypoints, saying why
// it likely has: few sampled (an object small for params.keypoint_radius), or many sampled and
// none with a frame or descriptor (supports too sparse, or points on a line). prepare_model calls it.
void require_model_keypoints(const Features& features, const FeatureParams& params, const std::string& where);

// A .mfpcm file name (the model cache below).
bool is_model_cache(const std::filesystem::path& path);

// The model a command was given: a cache as it was written, or a cloud (.pcd, .ply) described
// with `params`. With `check_cache_params`, a cache made with other parameters is stale for this
// run: an error naming the cache and `params_source` (where the parameters came from).
Model load_model(const std::filesystem::path& path, const FeatureParams& params, bool check_cache_params,
                 const std::string& params_source, FeatureTimings* timings = nullptr);

// The model cache (.mfpcm): a versioned binary file holding all of Model, so batch runs do not
// describe the model again. read_model_cache throws mfpc::Error for a file that is not a cache, a
// cache of another format version, or a truncated or corrupt one (checked by size and checksum).
void write_model_cache(const std::filesystem::path& path, const Model& model);
Model read_model_cache(const std::filesystem::path& path);
inline constexpr std::uint32_t model_cache_version = 2;  // 2: FeatureParams::resolution

}  // namespace mfpc
