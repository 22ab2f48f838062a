#pragma once

/// @file
/// @brief Scoring a recognition result against ground truth (paper Eq. 10 and 11, instance
/// matching).

#include <vector>

#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/recognize.hpp"

namespace mfpc {

/// @brief The tolerances of evaluate().
struct EvaluationParams {
    float correspondence_tolerance = 0.01f;  ///< Scene keypoint within this of the true model keypoint (m).
    float instance_translation = 0.02f;      ///< An instance is correct within 2 cm ...
    float instance_angle_deg = 10.0f;        ///< ... and 10 degrees of an unclaimed true instance.
    /// Beyond instance_angle_deg, a found instance within instance_translation still matches when
    /// the sensor would see the same surface at both poses (after the visible surface discrepancy
    /// of the BOP benchmark): a pose is only as determined as what can be seen of the object (a mug
    /// with its handle behind it, turned about its body). The model points seen at each pose
    /// (model_points_in_view: facing the sensor within 75 degrees, not hidden by the model itself)
    /// must lie within surface_tolerance (metres) of a point seen at the other pose, for at least
    /// surface_agreement of them each way. A surface_agreement above 1 turns the test off.
    float surface_tolerance = 0.01f;
    float surface_agreement = 0.95f;         ///< See surface_tolerance.
};

/// @brief How a recognition result compares with the ground truth.
struct Evaluation {
    std::size_t instances_true = 0;    ///< Found instances matched to a true instance.
    std::size_t instances_false = 0;   ///< Found instances matched to none.
    std::size_t instances_missed = 0;  ///< True instances no found instance matched.
    std::size_t correct_correspondences = 0;  ///< Correspondences that are correct (see evaluate()).
    /// (model keypoint, true instance) pairs with a scene keypoint within tolerance.
    std::size_t possible_correspondences = 0;
    double correspondence_precision = 0;      ///< Correct / all (Eq. 10); 0 without correspondences.
    /// Distinct pairs found correct / possible (Eq. 11); 0 when none is possible.
    double correspondence_sensitivity = 0;
    std::vector<int> instance_match;          ///< Per found instance: the true instance it matches, or -1.
    /// Of instances_true, those matched by their visible surface alone (turned more than
    /// EvaluationParams::instance_angle_deg from the truth).
    std::size_t instances_true_by_surface = 0;
    /// Per found instance: model centroid offset from the nearest true pose (m).
    std::vector<float> position_error;
    std::vector<float> rotation_error_deg;    ///< ... and rotation difference to it (degrees).
};

/// @brief Scores a recognition result against ground truth.
///
/// A correspondence is correct when its scene keypoint lies within correspondence_tolerance of its
/// model keypoint mapped by some true instance's transform; found instances are matched greedily
/// (in result order) to the nearest unclaimed true instance within the translation and angle
/// limits. For a symmetric object (the ground truth's "symmetry"), each of its equivalent
/// transforms counts as the true one. An instance turned further but at the right place matches
/// when the sensor would see the same surface of it (EvaluationParams::surface_tolerance).
/// @param result The recognition result: its correspondences and instances.
/// @param model The model recognised, whose keypoints the correspondences number.
/// @param truth The scene's ground truth.
/// @param params The tolerances.
/// @return The scores.
Evaluation evaluate(const RecognitionResult& result, const Model& model, const GroundTruth& truth,
                    const EvaluationParams& params = {});

}  // namespace mfpc
