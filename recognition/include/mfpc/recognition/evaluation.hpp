#pragma once

#include <vector>

#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/recognize.hpp"

namespace mfpc {

struct EvaluationParams {
    float correspondence_tolerance = 0.01f;  // scene keypoint within this of the true model keypoint
    float instance_translation = 0.02f;      // an instance is correct within 2 cm ...
    float instance_angle_deg = 10.0f;        // ... and 10 degrees of an unclaimed true instance
};

struct Evaluation {
    std::size_t instances_true = 0;
    std::size_t instances_false = 0;
    std::size_t instances_missed = 0;
    std::size_t correct_correspondences = 0;
    std::size_t possible_correspondences = 0;  // (model keypoint, true instance) pairs with a scene keypoint within tolerance
    double correspondence_precision = 0;      // correct / all (Eq. 10)
    double correspondence_sensitivity = 0;    // distinct pairs found correct / possible (Eq. 11)
    std::vector<int> instance_match;          // per found instance: the true instance it matches, or -1
    std::vector<float> position_error;        // per found instance: model centroid offset from the nearest true pose (m)
    std::vector<float> rotation_error_deg;    // ... and rotation difference to it
};

// Scores a recognition result against ground truth: a correspondence is correct when its scene
// keypoint lies within correspondence_tolerance of its model keypoint mapped by some true
// instance's transform; found instances are matched greedily (in result order) to the nearest
// unclaimed true instance within the translation and angle limits. For a symmetric object (the
// ground truth's "symmetry"), each of its equivalent transforms counts as the true one.
Evaluation evaluate(const RecognitionResult& result, const Model& model, const GroundTruth& truth,
                    const EvaluationParams& params = {});

}  // namespace mfpc
