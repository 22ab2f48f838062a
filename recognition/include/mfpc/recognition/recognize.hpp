#pragma once

#include <optional>
#include <vector>

#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/point_cloud.hpp"
#include "mfpc/kernels/foveate.hpp"
#include "mfpc/recognition/grouping.hpp"
#include "mfpc/recognition/matching.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

struct RecognitionCounts {
    std::size_t scene_points = 0;       // finite scene points
    std::size_t scene_points_foveated = 0;  // kept by foveation before downsampling (= scene_points without)
    std::size_t redundant_points = 0;       // points raw mode would repeat (paper Eq. 6; 0 without foveation)
    std::size_t scene_points_used = 0;  // described: after foveation, or the voxels at a working resolution (else = scene_points)
    std::size_t scene_keypoints = 0;    // with valid frame and descriptor
    std::size_t scene_keypoints_invalid = 0;
    std::size_t model_keypoints = 0;
    std::size_t model_keypoints_invalid = 0;
    std::size_t correspondences = 0;
    std::size_t instances_before_verification = 0;
};

// Milliseconds per stage of the scene work (model work is apart, in Model preparation).
struct RecognitionTimings {
    double foveate = 0, normals = 0, keypoints = 0, lrf = 0, descriptors = 0, match = 0, group = 0, verify = 0,
           total = 0;
};

struct RecognitionResult {
    std::vector<Instance> instances;
    Features scene_features;
    std::vector<Correspondence> correspondences;
    RecognitionCounts counts;
    RecognitionTimings timings;
    // The foveated cloud that was described, when SceneFoveation::keep_cloud asked for it (and the
    // scene was foveated); else empty.
    FoveatedCloud foveated;
};

struct SceneFoveation {
    const FoveationConfig* config = nullptr;  // none: the plain pipeline
    FoveationMode mode = FoveationMode::mfpc;
    int single_structure = 0;
    bool keep_cloud = false;  // return the foveated cloud in RecognitionResult::foveated
};

// The whole scene pipeline: foveate (optional), normals, keypoints (r per region when foveated),
// BOARD, SHOT, matching, grouping, refinement and verification (as params say).
RecognitionResult recognize(const Model& model, const PointCloud& scene, const RecognitionParams& params,
                            const SceneFoveation& foveation = {});

}  // namespace mfpc
