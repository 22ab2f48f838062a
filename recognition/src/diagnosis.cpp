#include "mfpc/recognition/diagnosis.hpp"

#include <algorithm>
#include <limits>
#include <optional>

#include "mfpc/core/error.hpp"
#include "mfpc/recognition/verification.hpp"

namespace mfpc {

const char* to_string(LossStage stage)
{
    switch (stage) {
    case LossStage::found: return "found";
    case LossStage::no_correspondence: return "no_correspondence";
    case LossStage::no_hypothesis: return "no_hypothesis";
    case LossStage::prefilter: return "prefilter";
    case LossStage::fitness: return "fitness";
    case LossStage::coverage: return "coverage";
    case LossStage::free_space: return "free_space";
    case LossStage::thickness: return "thickness";
    case LossStage::rim: return "rim";
    case LossStage::refined_away: return "refined_away";
    case LossStage::merged: return "merged";
    }
    return "?";
}

namespace {

// The first limit, in verification's order, that refuses an instance scored with every limit
// open; nothing when these four pass it (the prefilter or the rim refused it).
std::optional<LossStage> refusing_limit(const Instance& scored, const VerifyParams& verify)
{
    if (scored.fitness < verify.min_inlier_fraction) return LossStage::fitness;
    if (scored.coverage < verify.min_coverage) return LossStage::coverage;
    if (scored.free_space_violation > verify.max_free_space_fraction) return LossStage::free_space;
    if (scored.thickness_ratio < verify.min_thickness_ratio) return LossStage::thickness;
    return std::nullopt;
}

}  // namespace

std::vector<TruthDiagnosis> diagnose_truth(const DescribedScene& described, const Model& model,
                                           const RecognitionResult& result, const std::vector<Instance>& hypotheses,
                                           const GroundTruth& truth, const EvaluationParams& params)
{
    if (!described.evidence) throw Error("diagnose_truth", "the scene was described without verification evidence");
    const Evaluation evaluation = evaluate(result, model, truth, params);
    const Point centroid = model_centroid(model);
    const RecognitionParams& run = described.params;
    const float tolerance2 = params.correspondence_tolerance * params.correspondence_tolerance;
    std::vector<TruthDiagnosis> out(truth.instances.size());
    for (std::size_t t = 0; t < truth.instances.size(); ++t) {
        TruthDiagnosis& d = out[t];
        const std::vector<Pose> equivalent = truth.instances[t].equivalent_transforms();
        auto near_truth = [&](const Pose& pose, float scale) {
            for (const Pose& e : equivalent)
                if ((pose * centroid - e * centroid).norm() <= scale * params.instance_translation &&
                    rotation_error_deg(pose, e) <= scale * params.instance_angle_deg)
                    return true;
            return false;
        };
        for (const Correspondence& c : result.correspondences)
            for (const Pose& e : equivalent)
                if ((e * model.features.keypoints[c.model] - result.scene_features.keypoints[c.scene]).squaredNorm() <=
                    tolerance2) {
                    ++d.correct_correspondences;
                    break;
                }
        if (std::find(evaluation.instance_match.begin(), evaluation.instance_match.end(), int(t)) !=
            evaluation.instance_match.end())
            continue;  // found
        if (d.correct_correspondences == 0) {
            d.stage = LossStage::no_correspondence;
            continue;
        }
        for (std::size_t h = 0; h < hypotheses.size() && d.hypothesis < 0; ++h)
            if (near_truth(hypotheses[h].transform, 2.0f)) d.hypothesis = int(h);
        if (d.hypothesis < 0) {
            d.stage = LossStage::no_hypothesis;
            continue;
        }
        const Instance& hypothesis = hypotheses[std::size_t(d.hypothesis)];
        auto verify_alone = [&](const VerifyParams& verify) {
            return refine_and_verify({hypothesis}, model.points, model.normals, *described.evidence, run.refine, verify);
        };
        const std::vector<Instance> alone = verify_alone(run.verify);
        if (!alone.empty()) {
            d.stage = near_truth(alone[0].transform, 1.0f) ? LossStage::merged : LossStage::refined_away;
            continue;
        }
        VerifyParams open = run.verify;
        open.min_inlier_fraction = 0.0f;
        open.min_coverage = 0.0f;
        open.max_free_space_fraction = 1.0f;
        open.min_thickness_ratio = 0.0f;
        open.max_continuation = 1.0f;
        open.prefilter_coverage = 0.0f;
        const std::vector<Instance> scored = verify_alone(open);
        if (scored.empty()) {
            d.stage = LossStage::prefilter;
            continue;
        }
        if (const std::optional<LossStage> limit = refusing_limit(scored[0], run.verify)) {
            d.stage = *limit;
            continue;
        }
        VerifyParams no_prefilter = run.verify;
        no_prefilter.prefilter_coverage = 0.0f;
        d.stage = verify_alone(no_prefilter).empty() ? LossStage::rim : LossStage::prefilter;
    }
    return out;
}

}  // namespace mfpc
