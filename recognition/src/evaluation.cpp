#include "mfpc/recognition/evaluation.hpp"

#include <algorithm>
#include <limits>
#include <set>
#include <utility>

#include "mfpc/index/nearest_neighbors.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/recognition/verification.hpp"

namespace mfpc {

Evaluation evaluate(const RecognitionResult& result, const Model& model, const GroundTruth& truth,
                    const EvaluationParams& params)
{
    Evaluation out;
    const auto& scene = result.scene_features;
    const float tolerance2 = params.correspondence_tolerance * params.correspondence_tolerance;

    // A symmetric object sits identically under each of its equivalent transforms, and a keypoint
    // matched to its symmetric twin is as right as one matched to itself.
    std::vector<std::vector<Pose>> equivalent;
    for (const auto& t : truth.instances) equivalent.push_back(t.equivalent_transforms());

    // Correct correspondences, and the distinct (model keypoint, true instance) pairs they hit.
    std::set<std::pair<std::uint32_t, std::size_t>> hit;
    for (const auto& c : result.correspondences) {
        bool correct = false;
        for (std::size_t t = 0; t < truth.instances.size(); ++t) {
            for (const Pose& pose : equivalent[t]) {
                const Point expected = pose * model.features.keypoints[c.model];
                if ((expected - scene.keypoints[c.scene]).squaredNorm() <= tolerance2) {
                    correct = true;
                    hit.emplace(c.model, t);
                    break;
                }
            }
        }
        if (correct) ++out.correct_correspondences;
    }
    // Possible: a true instance's model keypoint has a scene keypoint within tolerance.
    if (scene.size() > 0) {
        const NeighborGrid grid(scene.keypoints, std::max(params.correspondence_tolerance, 1e-3f));
        std::vector<std::uint32_t> indices;
        std::vector<float> distances;
        for (std::size_t t = 0; t < truth.instances.size(); ++t)
            for (const Point& k : model.features.keypoints)
                for (const Pose& pose : equivalent[t]) {
                    grid.radius_search(pose * k, params.correspondence_tolerance, indices, distances);
                    if (!indices.empty()) {
                        ++out.possible_correspondences;
                        break;
                    }
                }
    }
    out.correspondence_precision =
        result.correspondences.empty() ? 0.0 : double(out.correct_correspondences) / double(result.correspondences.size());
    out.correspondence_sensitivity =
        out.possible_correspondences == 0 ? 0.0 : double(hit.size()) / double(out.possible_correspondences);

    // Instances: the object's position is the model centroid carried by the transform.
    const Point centroid = model_centroid(model);
    std::vector<std::uint8_t> claimed(truth.instances.size(), 0);
    // The visible-surface test, on the model's own points: thinned to a grid, a wall thinner than a
    // cell keeps one side or the other in patches. Its spacing is found when first asked.
    float spacing = -1.0f;
    auto seen_at = [&](const Pose& pose) {
        const float facing_cos = VerifyParams{}.min_facing_cos;  // a depth sensor's, as verification's
        const std::vector<std::uint8_t> seen = model_points_in_view(model.points, model.normals, pose, facing_cos, spacing);
        std::vector<Point> points;
        for (std::size_t i = 0; i < model.points.size(); ++i)
            if (seen[i]) points.push_back(pose * model.points[i]);
        return points;
    };
    auto agreement = [&](std::span<const Point> from, std::span<const Point> to) {
        const NeighborGrid grid(to, std::max(params.surface_tolerance, 1e-3f));
        std::size_t near = 0;
        for (const Point& p : from) {
            std::uint32_t index = 0;
            float d2 = 0.0f;
            near += grid.nearest(p, params.surface_tolerance, index, d2);
        }
        return double(near) / double(from.size());
    };
    auto same_surface = [&](const Pose& found, const Pose& true_pose) {
        if (params.surface_agreement > 1.0f || model.points.size() < 2 || model.points.size() != model.normals.size())
            return false;
        if (spacing < 0.0f) spacing = float(mean_spacing(model.points));
        const std::vector<Point> at_found = seen_at(found), at_truth = seen_at(true_pose);
        if (at_found.empty() || at_truth.empty()) return false;
        return agreement(at_found, at_truth) >= params.surface_agreement &&
               agreement(at_truth, at_found) >= params.surface_agreement;
    };
    for (const auto& instance : result.instances) {
        int match = -1;
        float best = params.instance_translation;
        float nearest = std::numeric_limits<float>::infinity();
        float nearest_angle = std::numeric_limits<float>::quiet_NaN();
        // The errors to a true instance: to the nearest of its equivalent transforms (the centroid
        // moves under a turn whose axis misses it).
        auto distance_to = [&](std::size_t t) {
            float distance = std::numeric_limits<float>::infinity();
            for (const Pose& pose : equivalent[t])
                distance = std::min(distance, (instance.transform * centroid - pose * centroid).norm());
            return distance;
        };
        auto angle_to = [&](std::size_t t) {
            float angle = std::numeric_limits<float>::infinity();
            for (const Pose& pose : equivalent[t]) angle = std::min(angle, rotation_error_deg(instance.transform, pose));
            return angle;
        };
        for (std::size_t t = 0; t < truth.instances.size(); ++t) {
            const float distance = distance_to(t);
            if (distance < nearest) {
                nearest = distance;
                nearest_angle = angle_to(t);
            }
        }
        out.position_error.push_back(nearest);
        out.rotation_error_deg.push_back(nearest_angle);
        bool by_surface = false;
        for (std::size_t t = 0; t < truth.instances.size(); ++t) {
            if (claimed[t]) continue;
            const float distance = distance_to(t);
            if (distance > best) continue;
            const bool turned = angle_to(t) > params.instance_angle_deg;
            if (turned && !same_surface(instance.transform, truth.instances[t].transform)) continue;
            best = distance;
            match = int(t);
            by_surface = turned;
        }
        out.instance_match.push_back(match);
        if (match >= 0) {
            claimed[std::size_t(match)] = 1;
            ++out.instances_true;
            out.instances_true_by_surface += by_surface;
        } else {
            ++out.instances_false;
        }
    }
    out.instances_missed = truth.instances.size() - out.instances_true;
    return out;
}

}  // namespace mfpc
