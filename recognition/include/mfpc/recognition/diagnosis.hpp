#pragma once

/// @file
/// @brief Where along the pipeline each true instance of a scene was lost: no correct
/// correspondence, no hypothesis near it, or the verification test that refused it.

#include <vector>

#include "mfpc/recognition/described_scene.hpp"
#include "mfpc/recognition/evaluation.hpp"
#include "mfpc/recognition/ground_truth.hpp"

namespace mfpc {

/// @brief The stage at which a true instance was lost (or `found`).
enum class LossStage {
    found,              ///< A found instance matches it.
    no_correspondence,  ///< No correspondence has its scene keypoint where the true pose puts the model keypoint.
    no_hypothesis,      ///< Correct correspondences, but no grouping hypothesis near the true pose.
    prefilter,          ///< The hypothesis near it explained too little before ICP (verify.prefilter_coverage).
    fitness,            ///< Refused: too few of its visible points fit (verify.min_inlier_fraction).
    coverage,           ///< Refused: too little of its facing side explained (verify.min_coverage).
    free_space,         ///< Refused: the sensor saw through it (verify.max_free_space_fraction).
    thickness,          ///< Refused: its fitting points are flat where it is not (verify.min_thickness_ratio).
    rim,                ///< Refused: the scene goes on past its edges (verify.max_continuation).
    refined_away,       ///< Accepted alone, but ICP took it off the true pose.
    merged,             ///< Accepted alone at the true pose, but not among the others (a merge or a settled instance).
};

/// @brief The name of a loss stage, as reports write it.
/// @param stage The stage.
/// @return "found", "no_correspondence", "no_hypothesis", "prefilter", "fitness", "coverage",
/// "free_space", "thickness", "rim", "refined_away" or "merged".
const char* to_string(LossStage stage);

/// @brief What diagnose_truth found of one true instance.
struct TruthDiagnosis {
    LossStage stage = LossStage::found;     ///< Where it was lost.
    std::size_t correct_correspondences = 0;  ///< Correspondences correct for this instance (evaluate()'s tolerance).
    int hypothesis = -1;  ///< The grouping hypothesis near it (its rank), -1 when none.
};

/// @brief Says, for each true instance that a result missed, where it was lost.
///
/// For each true instance (its symmetric poses included): the correspondences whose scene keypoint
/// lies within the evaluation's correspondence tolerance of the model keypoint carried by the true
/// pose; then the first hypothesis, in grouping's order, within twice the evaluation's translation
/// and angle limits of the true pose (what ICP can be expected to bring onto it); then that
/// hypothesis verified alone, as the result's parameters say, and again with each limit open in
/// turn, to name the first limit that refuses it. It refines and verifies again, so it costs about
/// what verification of a few hypotheses costs per missed instance.
/// @param described The scene as it was described for the result.
/// @param model The model the result is of.
/// @param result The result (its correspondences, its scene features, its instances).
/// @param hypotheses Grouping's instances before verification (recognize_described gives them).
/// @param truth The scene's ground truth.
/// @param params The evaluation's tolerances.
/// @return One diagnosis per true instance, in the ground truth's order.
/// @throws mfpc::Error when the scene was described without verification evidence, or as
/// refine_and_verify.
std::vector<TruthDiagnosis> diagnose_truth(const DescribedScene& described, const Model& model,
                                           const RecognitionResult& result, const std::vector<Instance>& hypotheses,
                                           const GroundTruth& truth, const EvaluationParams& params = {});

}  // namespace mfpc
