#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "mfpc/core/pose.hpp"

namespace mfpc {

// Ground truth of a scene (the shared *.gt.json format):
//   {"model": "<file>", "instances": [{"transform": [16 numbers, row-major 4x4]}, ...]}
// Each transform maps model coordinates into scene coordinates. Instances may carry an "object"
// name and a "visible_points" count (written by the synthetic scanner); both are optional.
struct GroundTruthInstance {
    Pose transform = Pose::Identity();
    std::string object;
    long visible_points = -1;  // -1 when not given
};

struct GroundTruth {
    std::string model;
    std::vector<GroundTruthInstance> instances;
};

// Throws mfpc::Error naming the file and the key on any malformed input.
GroundTruth read_ground_truth(const std::filesystem::path& path);

}  // namespace mfpc
