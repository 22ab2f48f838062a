#include "mfpc/recognition/verification.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "mfpc/kernels/uniform_sampling.hpp"

namespace mfpc {
namespace {

// Whether a model point placed at p (camera frame) by `pose` turns its surface to the sensor; a
// point without a normal (a degenerate neighbourhood) gives no evidence either way.
bool faces_camera(const Pose& pose, const Point& p, const Point& normal)
{
    return normal.allFinite() && (pose.linear() * normal).dot(-p) > 0.0f;
}

// Thinner than this, the side of a model turned to the sensor is flat (metres).
constexpr float flat_side = 0.002f;

// The spread of points off their best plane: the square root of the smallest eigenvalue of their
// covariance.
struct Spread {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d products = Eigen::Matrix3d::Zero();
    std::size_t count = 0;

    void add(const Point& p)
    {
        const Eigen::Vector3d q = p.cast<double>();
        sum += q;
        products += q * q.transpose();
        ++count;
    }
    float thickness() const
    {
        if (count < 3) return 0.0f;
        const Eigen::Vector3d mean = sum / double(count);
        const Eigen::Matrix3d covariance = products / double(count) - mean * mean.transpose();
        const double smallest =
            Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance, Eigen::EigenvaluesOnly).eigenvalues()[0];
        return float(std::sqrt(std::max(smallest, 0.0)));
    }
};

struct Fit {
    Pose pose;
    float rmse = 0.0f;
};

Fit icp(const Pose& start, std::span<const Point> model, const SceneEvidence& scene, const RefineParams& params)
{
    Fit fit{start, 0.0f};
    std::vector<Point> from, to;
    for (int it = 0; it < params.iterations; ++it) {
        from.clear();
        to.clear();
        double squared_sum = 0.0;
        for (const Point& m : model) {
            const Point moved = fit.pose * m;
            std::uint32_t nearest = 0;
            float d2 = 0.0f;
            if (!scene.grid->nearest(moved, params.max_distance, nearest, d2)) continue;
            from.push_back(moved);
            to.push_back(scene.points[nearest]);
            squared_sum += d2;
        }
        if (from.size() < 3) break;
        fit.rmse = float(std::sqrt(squared_sum / double(from.size())));
        const Pose step = fit_rigid(from, to);
        fit.pose = step * fit.pose;
        if (step.translation().norm() < 1e-6f && rotation_error_deg(step, Pose::Identity()) < 1e-4f) break;
    }
    return fit;
}

}  // namespace

SceneEvidence make_scene_evidence(const PointCloud& scene, const NeighborGrid& grid, std::optional<Camera> camera)
{
    SceneEvidence evidence;
    evidence.points = scene.points;
    evidence.grid = &grid;
    evidence.camera = camera;
    if (evidence.camera) {
        evidence.depth.assign(scene.source_size(), std::numeric_limits<float>::quiet_NaN());
        for (std::size_t i = 0; i < scene.size(); ++i) evidence.depth[scene.source_position(i)] = scene.points[i].z();
    }
    return evidence;
}

std::vector<Instance> refine_and_verify(std::vector<Instance> instances, std::span<const Point> model_points,
                                        std::span<const Point> model_normals, const SceneEvidence& scene,
                                        const RefineParams& refine, const VerifyParams& verify)
{
    if (!refine.enabled && !verify.enabled) return instances;
    if (model_normals.size() != model_points.size())
        throw Error("refine_and_verify", "the model has " + std::to_string(model_normals.size()) + " normals for " +
                                             std::to_string(model_points.size()) + " points");
    if (scene.grid == nullptr) throw Error("refine_and_verify", "no scene grid");

    // Thin the model once: ICP and the fit statistics need its shape, not every point.
    std::vector<std::uint32_t> kept;
    if (refine.model_voxel > 0.0f) kept = uniform_sampling(model_points, refine.model_voxel);
    else
        for (std::uint32_t i = 0; i < model_points.size(); ++i) kept.push_back(i);
    std::vector<Point> points, normals;
    for (std::uint32_t i : kept) {
        points.push_back(model_points[i]);
        normals.push_back(model_normals[i]);
    }

    tbb::parallel_for(std::size_t(0), instances.size(), [&](std::size_t n) {
        Instance& instance = instances[n];
        // A hypothesis that explains less than three quarters of the coverage asked for, even with
        // the looser ICP distance, will not make it: reject it before paying for ICP (most Hough
        // maxima in clutter are such; true ones start within a centimetre).
        if (verify.enabled) {
            std::size_t near = 0, facing = 0;
            const float radius = std::max(refine.max_distance, verify.inlier_distance);
            for (std::size_t i = 0; i < points.size(); ++i) {
                const Point p = instance.transform * points[i];
                if (!faces_camera(instance.transform, p, normals[i])) continue;
                ++facing;
                std::uint32_t nearest = 0;
                float d2 = 0.0f;
                if (scene.grid->nearest(p, radius, nearest, d2)) ++near;
            }
            if (float(near) < 0.75f * verify.min_coverage * float(facing) || facing == 0) {
                instance.fitness = 0.0f;
                instance.coverage = 0.0f;
                return;
            }
        }
        if (refine.enabled) {
            const Fit fit = icp(instance.transform, points, scene, refine);
            instance.transform = fit.pose;
            instance.rmse = fit.rmse;
        }
        if (!verify.enabled) return;
        std::size_t facing = 0, visible = 0, inliers = 0, projected = 0, violations = 0;
        Spread facing_spread, inlier_spread;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const Point p = instance.transform * points[i];
            // Free space, for every model point whichever way its surface faces: a solid object
            // there would have stopped the sensor's ray, so a surface observed behind it refutes it.
            bool hidden = false;
            if (scene.camera && p.z() > 0.0f) {
                const Camera& c = *scene.camera;
                const long u = std::lround(c.fx * p.x() / p.z() + c.cx);
                const long v = std::lround(c.fy * p.y() / p.z() + c.cy);
                if (u >= 0 && v >= 0 && u < long(c.width) && v < long(c.height)) {
                    const float observed = scene.depth[std::size_t(v) * c.width + std::size_t(u)];
                    if (std::isfinite(observed)) {
                        ++projected;
                        if (observed > p.z() + verify.free_space_margin) ++violations;
                        // Something in front hides the point: no evidence for or against it.
                        hidden = observed < p.z() - verify.free_space_margin;
                    }
                }
            }
            if (!faces_camera(instance.transform, p, normals[i])) continue;
            ++facing;
            facing_spread.add(p);
            // Fitness, over the points the sensor could have seen: facing it, and not hidden.
            if (hidden) continue;
            ++visible;
            std::uint32_t nearest = 0;
            float d2 = 0.0f;
            if (scene.grid->nearest(p, verify.inlier_distance, nearest, d2)) {
                ++inliers;
                inlier_spread.add(p);
            }
        }
        // A side of the model that is itself flat (a box seen face on) cannot be told from a face
        // laid on a table by its shape: the test passes it.
        const float facing_thickness = facing_spread.thickness();
        instance.thickness_ratio = facing_thickness < flat_side ? 1.0f : inlier_spread.thickness() / facing_thickness;
        instance.fitness = visible ? float(inliers) / float(visible) : 0.0f;
        instance.coverage = facing ? float(inliers) / float(facing) : 0.0f;
        instance.free_space_violation = projected ? float(violations) / float(projected) : 0.0f;
    });
    if (!verify.enabled) return instances;

    std::vector<Instance> accepted;
    for (auto& instance : instances)
        if (instance.fitness >= verify.min_inlier_fraction && instance.coverage >= verify.min_coverage &&
            instance.free_space_violation <= verify.max_free_space_fraction &&
            instance.thickness_ratio >= verify.min_thickness_ratio)
            accepted.push_back(std::move(instance));
    if (!verify.merge) return accepted;
    // Duplicates: two solid objects cannot share space, so an instance whose placed model overlaps
    // a better one's (merge_overlap of its points within merge_distance of the other's) is the same
    // object posed twice: a near-symmetric carton turned half a turn, or slid along its own face.
    // The better fit (then the earlier) stays; the original order is kept.
    std::vector<std::size_t> by_fitness(accepted.size());
    for (std::size_t i = 0; i < by_fitness.size(); ++i) by_fitness[i] = i;
    std::stable_sort(by_fitness.begin(), by_fitness.end(),
                     [&](std::size_t a, std::size_t b) { return accepted[a].fitness > accepted[b].fitness; });
    std::vector<std::uint8_t> keep(accepted.size(), 0);
    std::vector<std::vector<Point>> kept_points;
    std::vector<std::unique_ptr<NeighborGrid>> kept_grids;
    std::vector<std::uint32_t> indices;
    std::vector<float> distances;
    for (std::size_t i : by_fitness) {
        std::vector<Point> placed(points.size());
        for (std::size_t p = 0; p < points.size(); ++p) placed[p] = accepted[i].transform * points[p];
        bool duplicate = false;
        for (const auto& grid : kept_grids) {
            std::size_t close = 0;
            for (const Point& p : placed) {
                grid->radius_search(p, verify.merge_distance, indices, distances);
                if (!indices.empty()) ++close;
            }
            if (!placed.empty() && float(close) >= verify.merge_overlap * float(placed.size())) {
                duplicate = true;
                break;
            }
        }
        if (duplicate) continue;
        keep[i] = 1;
        kept_points.push_back(std::move(placed));
        kept_grids.push_back(std::make_unique<NeighborGrid>(kept_points.back(), std::max(verify.merge_distance, 1e-3f)));
    }
    std::vector<Instance> merged;
    for (std::size_t i = 0; i < accepted.size(); ++i)
        if (keep[i]) merged.push_back(std::move(accepted[i]));
    return merged;
}

}  // namespace mfpc
