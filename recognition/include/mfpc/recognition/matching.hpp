#pragma once

#include <cstdint>
#include <vector>

#include "mfpc/recognition/features.hpp"
#include "mfpc/recognition/params.hpp"

namespace mfpc {

struct Correspondence {
    std::uint32_t model = 0;  // keypoint index in the model's Features
    std::uint32_t scene = 0;  // keypoint index in the scene's Features
    float distance = 0.0f;    // squared descriptor distance
    friend bool operator==(const Correspondence&, const Correspondence&) = default;
};

// Descriptor correspondences (nearest 352-D SHOT descriptors, found as params.search says) with
// squared distance below params.threshold, sorted by (model, scene). Deterministic at any thread
// count (randomized search excepted, see MatchSearch).
std::vector<Correspondence> match_descriptors(const Features& model, const Features& scene, const MatchParams& params);

}  // namespace mfpc
