#pragma once

/// @file
/// @brief Descriptor correspondences between a model and a scene (nearest SHOT352 descriptors).

#include <cstdint>
#include <vector>

#include "mfpc/recognition/features.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

/// @brief A model keypoint and a scene keypoint whose descriptors match.
struct Correspondence {
    std::uint32_t model = 0;  ///< Keypoint index in the model's Features.
    std::uint32_t scene = 0;  ///< Keypoint index in the scene's Features.
    float distance = 0.0f;    ///< Squared descriptor distance.
    /// @brief Whether the two correspondences are the same pair with the same distance.
    /// @return True when model, scene and distance all match.
    friend bool operator==(const Correspondence&, const Correspondence&) = default;
};

/// @brief Descriptor correspondences (nearest 352-D SHOT descriptors, found as params.search says)
/// with squared distance below params.threshold, sorted by (model, scene). Deterministic at any
/// thread count (randomized search excepted, see MatchSearch).
/// @param model The model's features.
/// @param scene The scene's features.
/// @param params The search, its direction, k and the threshold.
/// @return The correspondences; none when either has no keypoints.
/// @throws mfpc::Error for a threshold that is not positive, k below 1, or randomized search with
/// trees or checks below 1.
std::vector<Correspondence> match_descriptors(const Features& model, const Features& scene, const MatchParams& params);

}  // namespace mfpc
