#include "mfpc/recognition/placement.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iterator>
#include <map>
#include <numeric>
#include <random>

#include <Eigen/Eigenvalues>
#include <nlohmann/json.hpp>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "mfpc/kernels/voxel_grid.hpp"
#include "mfpc/recognition/described_scene.hpp"
#include "clusters.hpp"
#include "json_fields.hpp"

namespace mfpc {
namespace {

using Clock = std::chrono::steady_clock;

Box grown(const Box& box, float margin)
{
    return {box.min.array() - margin, box.max.array() + margin};
}

// Every strategy sizes its structures here, so they differ only in where they put them.
FoveatedStructure structure_around(const Box& object, const PlacementParams& params, const FeatureParams& scene,
                                   std::string name)
{
    const Box fovea = grown(object, params.fovea_margin);
    LevelDetail detail;
    detail.density_fovea = scene.resolution;
    detail.density_outer =
        scene.resolution > 0 ? params.outer_density_factor * scene.resolution : scene.keypoint_radius;
    detail.keypoint_radius_fovea = scene.keypoint_radius;
    detail.keypoint_radius_outer = params.outer_density_factor * scene.keypoint_radius;
    return structure_between(grown(fovea, params.outer_margin), fovea, params.levels, detail, std::move(name));
}

// The cloud's finite points: the points themselves, as PointCloud holds them; a filtered copy in
// `storage` only for a cloud built around the reader that holds some that are not.
std::span<const Point> finite_points(const PointCloud& scene, std::vector<Point>& storage)
{
    const auto finite = [](const Point& p) { return p.allFinite(); };
    if (std::all_of(scene.points.begin(), scene.points.end(), finite)) return scene.points;
    std::copy_if(scene.points.begin(), scene.points.end(), std::back_inserter(storage), finite);
    return storage;
}

struct Plane {
    Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();
    float offset = 0;  // normal . p + offset = 0 on the plane
    float distance(const Point& p) const { return std::abs(normal.dot(p) + offset); }
};

// Least-squares plane of the points `members` names: through their centroid, normal along the
// smallest axis of their spread. Also gives the two in-plane axes' extents.
Plane fit_plane(std::span<const Point> points, std::span<const std::uint32_t> members, Eigen::Vector2f* span_out)
{
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (auto i : members) mean += points[i].cast<double>();
    mean /= double(members.size());
    Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
    for (auto i : members) {
        const Eigen::Vector3d d = points[i].cast<double>() - mean;
        spread += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(spread);
    Plane plane;
    plane.normal = solver.eigenvectors().col(0).cast<float>().normalized();
    plane.offset = -plane.normal.dot(mean.cast<float>());
    if (span_out) {
        const Eigen::Vector3f u = solver.eigenvectors().col(2).cast<float>();
        const Eigen::Vector3f v = solver.eigenvectors().col(1).cast<float>();
        Eigen::Vector2f lo = Eigen::Vector2f::Constant(INFINITY), hi = Eigen::Vector2f::Constant(-INFINITY);
        for (auto i : members) {
            const Eigen::Vector2f q(u.dot(points[i]), v.dot(points[i]));
            lo = lo.cwiseMin(q);
            hi = hi.cwiseMax(q);
        }
        *span_out = hi - lo;
    }
    return plane;
}

// RANSAC for the plane with the most inliers among `candidates`. Draws come from a fixed seed and
// every draw is scored on its own, so the winner (most inliers, then the earliest draw) is the
// same at any thread count.
std::vector<std::uint32_t> best_plane_inliers(std::span<const Point> points, std::span<const std::uint32_t> candidates,
                                              const PlacementParams& params, std::uint32_t seed)
{
    const std::size_t n = candidates.size();
    std::mt19937 random(seed);
    std::uniform_int_distribution<std::size_t> pick(0, n - 1);
    std::vector<std::array<std::size_t, 3>> draws(std::size_t(params.plane_iterations));
    for (auto& draw : draws) draw = {pick(random), pick(random), pick(random)};
    std::vector<std::size_t> score(draws.size(), 0);
    tbb::parallel_for(std::size_t(0), draws.size(), [&](std::size_t d) {
        const Point& a = points[candidates[draws[d][0]]];
        const Point& b = points[candidates[draws[d][1]]];
        const Point& c = points[candidates[draws[d][2]]];
        const Eigen::Vector3f normal = (b - a).cross(c - a);
        const float norm = normal.norm();
        if (!(norm > 1e-9f)) return;
        Plane plane;
        plane.normal = normal / norm;
        plane.offset = -plane.normal.dot(a);
        std::size_t count = 0;
        for (auto i : candidates) count += plane.distance(points[i]) <= params.plane_distance;
        score[d] = count;
    });
    const std::size_t best = std::size_t(std::max_element(score.begin(), score.end()) - score.begin());
    if (score[best] < 3) return {};
    auto inliers_of = [&](const Plane& plane) {
        std::vector<std::uint32_t> inliers;
        for (auto i : candidates)
            if (plane.distance(points[i]) <= params.plane_distance) inliers.push_back(i);
        return inliers;
    };
    const Point& a = points[candidates[draws[best][0]]];
    Plane plane;
    plane.normal = (points[candidates[draws[best][1]]] - a).cross(points[candidates[draws[best][2]]] - a).normalized();
    plane.offset = -plane.normal.dot(a);
    // One least-squares pass over the draw's inliers: the draw's three voxels carry their noise.
    return inliers_of(fit_plane(points, inliers_of(plane), nullptr));
}

float largest_extent(std::span<const Model* const> models)
{
    float extent = 0;
    for (const Model* model : models) extent = std::max(extent, model_extent(*model));
    return extent;
}

// What segments and track share: the object-sized clusters left once the supporting planes are gone.
std::vector<Box> segment_clusters(std::span<const Point> voxels, std::span<const Model* const> models,
                                  const PlacementParams& params, PlacementResult& result)
{
    if (voxels.empty()) return {};
    const float extent = largest_extent(models);
    std::size_t min_voxels = std::size_t(params.min_cluster_voxels);
    std::size_t smallest = SIZE_MAX;
    for (const Model* model : models) smallest = std::min(smallest, voxel_grid(model->points, params.voxel).centroids.size());
    min_voxels = std::max(min_voxels, std::size_t(std::ceil(params.min_cluster_share * double(smallest))));
    std::vector<std::uint32_t> left(voxels.size());
    std::iota(left.begin(), left.end(), 0u);
    for (int p = 0; p < params.max_planes && left.size() >= 3; ++p) {
        std::vector<std::uint32_t> inliers = best_plane_inliers(voxels, left, params, 0x9e3779b9u + std::uint32_t(p));
        // A support is one connected piece of the plane: the plane through a carton's face also
        // passes through scattered voxels across the room, which would make the face look wide.
        std::vector<std::vector<std::uint32_t>> pieces = detail::clusters_of(voxels, inliers, params.cluster_gap);
        if (pieces.empty()) break;
        inliers = std::move(*std::max_element(pieces.begin(), pieces.end(), [](const auto& a, const auto& b) {
            return a.size() < b.size();
        }));
        std::sort(inliers.begin(), inliers.end());
        if (inliers.size() < 3 || double(inliers.size()) < params.min_plane_fraction * double(left.size())) break;
        Eigen::Vector2f span;
        fit_plane(voxels, inliers, &span);
        // The largest plane that is no support (an object's face, a box top) ends the search:
        // the planes after it are smaller still.
        if (span.maxCoeff() <= params.min_plane_span * extent) break;
        std::vector<std::uint32_t> rest;
        std::set_difference(left.begin(), left.end(), inliers.begin(), inliers.end(), std::back_inserter(rest));
        left = std::move(rest);
        ++result.planes;
    }
    std::vector<Box> objects;
    for (const auto& cluster : detail::clusters_of(voxels, left, params.cluster_gap)) {
        if (cluster.size() < min_voxels) continue;
        ++result.clusters;
        Box box = bounding_box({});
        for (auto i : cluster) box.extend(voxels[i]);
        // Voxel centroids lie up to half a voxel inside the surface they stand for.
        box = grown(box, 0.5f * params.voxel);
        if (box.size().maxCoeff() > params.max_cluster_factor * extent) {
            ++result.clusters_too_large;
            continue;
        }
        objects.push_back(box);
    }
    return objects;
}

std::vector<Box> grid_cells(std::span<const Point> voxels, float cell, const PlacementParams& params)
{
    if (voxels.empty()) return {};
    const Box bounds = bounding_box(voxels);
    std::map<std::array<std::int64_t, 3>, Box> cells;  // ordered: the structures' order is the cells'
    for (const Point& p : voxels) {
        const Eigen::Array3f at = ((p - bounds.min) / cell).array().floor();
        const std::array<std::int64_t, 3> key = {std::int64_t(at.z()), std::int64_t(at.y()), std::int64_t(at.x())};
        auto [it, fresh] = cells.try_emplace(key, bounding_box({}));
        it->second.extend(p);
    }
    std::vector<Box> boxes;
    for (const auto& [key, box] : cells) boxes.push_back(grown(box, 0.5f * params.voxel));
    return boxes;
}

std::vector<Box> coarse_hypotheses(const PointCloud& scene, std::span<const Model* const> models,
                                   const RecognitionParams& recognition, const PlacementParams& params,
                                   PlacementResult& result)
{
    RecognitionParams coarse = recognition;
    coarse.scene.resolution *= params.coarse_factor;
    coarse.scene.keypoint_radius *= params.coarse_factor;
    coarse.refine.enabled = false;
    coarse.verify.enabled = false;
    struct Hypothesis {
        float votes;
        std::size_t model, order;
        Box box;
    };
    std::vector<Hypothesis> hypotheses;
    const std::vector<RecognitionResult> found = recognize_models(models, scene, coarse);
    for (std::size_t m = 0; m < found.size(); ++m)
        for (std::size_t i = 0; i < found[m].instances.size(); ++i)
            hypotheses.push_back({found[m].instances[i].votes, m, i,
                                  placed_model_box(*models[m], found[m].instances[i].transform)});
    result.hypotheses = hypotheses.size();
    std::stable_sort(hypotheses.begin(), hypotheses.end(),
                     [](const Hypothesis& a, const Hypothesis& b) { return a.votes > b.votes; });
    if (hypotheses.size() > std::size_t(params.coarse_hypotheses)) hypotheses.resize(std::size_t(params.coarse_hypotheses));
    std::vector<Box> boxes;
    for (const Hypothesis& h : hypotheses) boxes.push_back(h.box);
    return boxes;
}

bool intersects_any(const Box& box, std::span<const Box> others)
{
    return std::any_of(others.begin(), others.end(), [&](const Box& other) { return box.intersects(other); });
}

// track: segments' clusters where followed instances are (a followed box, grown for the motion,
// that holds no cluster's centre is placed itself), and every cluster when the frame is due for a look at
// what is new or nothing is followed.
std::vector<Box> track_objects(std::span<const Point> voxels, std::span<const Model* const> models,
                               PlacementTrack& track, const PlacementParams& params, PlacementResult& result)
{
    std::vector<Box> followed;
    for (const auto& entry : track.followed) followed.push_back(grown(entry.first, params.track_margin));
    result.followed = followed.size();
    result.searched = followed.empty() || track.frame % std::uint64_t(params.track_refresh) == 0;
    ++track.frame;
    const std::vector<Box> clusters = segment_clusters(voxels, models, params, result);
    // A cluster is the followed object when its centre lies in the object's grown box: objects
    // stand a centimetre apart on a table, so a neighbour's box meets the grown box but its centre
    // lies beyond it.
    auto centred_in = [](const Box& cluster, const Box& box) { return box.contains(cluster.center()); };
    std::vector<Box> objects;
    for (const Box& cluster : clusters)
        if (result.searched ||
            std::any_of(followed.begin(), followed.end(), [&](const Box& box) { return centred_in(cluster, box); }))
            objects.push_back(cluster);
    for (const Box& box : followed)
        if (std::none_of(clusters.begin(), clusters.end(), [&](const Box& cluster) { return centred_in(cluster, box); }))
            objects.push_back(box);
    return objects;
}

}  // namespace

const char* to_string(PlacementStrategy strategy)
{
    switch (strategy) {
    case PlacementStrategy::segments: return "segments";
    case PlacementStrategy::coarse: return "coarse";
    case PlacementStrategy::grid: return "grid";
    case PlacementStrategy::track: return "track";
    case PlacementStrategy::oracle: return "oracle";
    }
    return "?";
}

PlacementStrategy parse_placement_strategy(std::string_view text, const std::string& where)
{
    for (PlacementStrategy s : {PlacementStrategy::segments, PlacementStrategy::coarse, PlacementStrategy::grid,
                                PlacementStrategy::track, PlacementStrategy::oracle})
        if (text == to_string(s)) return s;
    throw Error(where, "'" + std::string(text) + "' is not one of segments, coarse, grid, track, oracle");
}

void check_placement_params(const PlacementParams& params, const std::string& source)
{
    auto positive = [&](float value, const char* key) {
        if (!(value > 0 && std::isfinite(value))) throw Error(source + ": " + key, "must be positive and finite");
    };
    auto at_least = [&](int value, int low, int high, const char* key) {
        if (value < low || value > high)
            throw Error(source + ": " + key, "must lie in " + std::to_string(low) + ".." + std::to_string(high));
    };
    at_least(params.levels, 1, max_levels, "levels");
    if (!(params.fovea_margin >= 0 && std::isfinite(params.fovea_margin)))
        throw Error(source + ": fovea_margin", "must be finite and not negative");
    positive(params.outer_margin, "outer_margin");
    if (!(params.outer_density_factor >= 1 && std::isfinite(params.outer_density_factor)))
        throw Error(source + ": outer_density_factor", "must be at least 1 and finite");
    positive(params.voxel, "voxel");
    positive(params.plane_distance, "plane_distance");
    at_least(params.max_planes, 0, 100, "max_planes");
    if (!(params.min_plane_fraction >= 0 && params.min_plane_fraction <= 1))
        throw Error(source + ": min_plane_fraction", "must lie in [0, 1]");
    positive(params.min_plane_span, "min_plane_span");
    at_least(params.plane_iterations, 1, 1000000, "plane_iterations");
    positive(params.cluster_gap, "cluster_gap");
    at_least(params.min_cluster_voxels, 1, 100000000, "min_cluster_voxels");
    if (!(params.min_cluster_share >= 0 && params.min_cluster_share <= 1))
        throw Error(source + ": min_cluster_share", "must lie in [0, 1]");
    positive(params.max_cluster_factor, "max_cluster_factor");
    if (!(params.max_fovea_fraction >= 0 && params.max_fovea_fraction <= 1))
        throw Error(source + ": max_fovea_fraction", "must lie in [0, 1]");
    if (!(params.coarse_factor >= 1 && std::isfinite(params.coarse_factor)))
        throw Error(source + ": coarse_factor", "must be at least 1 and finite");
    at_least(params.coarse_hypotheses, 1, 100000, "coarse_hypotheses");
    if (!(params.grid_cell == 0 || (params.grid_cell >= params.voxel && std::isfinite(params.grid_cell))))
        throw Error(source + ": grid_cell", "must be 0 (the largest model's extent) or a finite size of at least voxel");
    at_least(params.track_refresh, 1, 1000000, "track_refresh");
    if (!(params.track_margin >= 0 && std::isfinite(params.track_margin)))
        throw Error(source + ": track_margin", "must be finite and not negative");
}

Box placed_model_box(const Model& model, const Pose& transform)
{
    Box box = bounding_box({});
    for (const Point& p : model.points) box.extend(Point(transform * p));
    return box;
}

float model_extent(const Model& model)
{
    const Box box = bounding_box(model.points);
    return box.valid() ? box.size().norm() : 0.0f;
}

PlacementResult place_foveae(const PointCloud& scene, std::span<const Model* const> models,
                             const RecognitionParams& recognition, const PlacementParams& params,
                             std::span<const PlacedInstance> truth, PlacementTrack* track)
{
    const auto start = Clock::now();
    check_placement_params(params);
    check_recognition_params(recognition);
    if (models.empty()) throw Error("placement", "needs at least one model");
    for (const Model* model : models) {
        if (!model) throw Error("placement", "a model is null");
        const std::string name = model->source.empty() ? "placement" : model->source;
        if (model->points.empty()) throw Error(name, "the model has no points");
        // The extent sizes supports, clusters and grid cells: a model no larger than a voxel has none.
        if (!(model_extent(*model) > params.voxel))
            throw Error(name, "the model is no larger than placement's voxel (" + format_number(params.voxel) +
                                  " m): nothing to size structures by");
    }
    if (params.strategy == PlacementStrategy::track && !track)
        throw Error("placement", "track needs the state carried from frame to frame");
    for (const PlacedInstance& instance : truth)
        if (instance.model >= models.size())
            throw Error("placement", "an instance names model " + std::to_string(instance.model) + " of " +
                                         std::to_string(models.size()));

    PlacementResult result;
    result.strategy = params.strategy;
    // The working cloud: one point per voxel, so every count and distance below is metric.
    std::vector<Point> voxels;
    if (params.strategy != PlacementStrategy::oracle) {
        std::vector<Point> storage;
        const std::span<const Point> points = finite_points(scene, storage);
        if (!points.empty()) voxels = voxel_grid(points, params.voxel).centroids;
    }
    std::vector<Box> objects;
    std::string label;
    switch (params.strategy) {
    case PlacementStrategy::segments:
        objects = segment_clusters(voxels, models, params, result);
        label = "cluster";
        break;
    case PlacementStrategy::track:
        objects = track_objects(voxels, models, *track, params, result);
        label = "cluster";
        break;
    case PlacementStrategy::coarse:
        // A cloud without a finite point has nothing to recognise: no hypothesis.
        if (!voxels.empty()) objects = coarse_hypotheses(scene, models, recognition, params, result);
        label = "hypothesis";
        break;
    case PlacementStrategy::grid:
        objects = grid_cells(voxels, params.grid_cell > 0 ? params.grid_cell : largest_extent(models), params);
        label = "cell";
        break;
    case PlacementStrategy::oracle:
        for (const PlacedInstance& instance : truth)
            objects.push_back(placed_model_box(*models[instance.model], instance.transform));
        label = "instance";
        break;
    }
    std::string too_much;
    if (params.strategy != PlacementStrategy::grid && params.strategy != PlacementStrategy::oracle && !voxels.empty() &&
        !objects.empty()) {
        std::vector<Box> foveae;
        for (const Box& object : objects) foveae.push_back(grown(object, params.fovea_margin));
        std::size_t inside = 0;
        for (const Point& p : voxels)
            inside += std::any_of(foveae.begin(), foveae.end(), [&](const Box& box) { return box.contains(p); });
        result.fovea_fraction = double(inside) / double(voxels.size());
        if (result.fovea_fraction > params.max_fovea_fraction) {
            char text[96];
            std::snprintf(text, sizeof text, "%zu foveae would hold %.0f%% of the scene", objects.size(),
                          100.0 * result.fovea_fraction);
            too_much = text;
            objects.clear();
        }
    }
    result.config.downsample = Downsample::voxel;
    for (std::size_t i = 0; i < objects.size(); ++i)
        result.config.structures.push_back(
            structure_around(objects[i], params, recognition.scene, label + " " + std::to_string(i)));
    result.objects = std::move(objects);
    if (result.config.structures.empty()) {
        std::string why = too_much;
        if (why.empty()) {
            switch (params.strategy) {
            case PlacementStrategy::segments:
            case PlacementStrategy::track:
                why = std::to_string(result.clusters) + " clusters, " + std::to_string(result.clusters_too_large) +
                      " longer than an object";
                break;
            case PlacementStrategy::coarse: why = "no hypothesis"; break;
            case PlacementStrategy::grid: why = "no finite point"; break;
            case PlacementStrategy::oracle: why = "no instance"; break;
            }
        }
        result.fallback = std::string(to_string(params.strategy)) + " placed no structure (" + why +
                          "): the scene runs without foveation";
    }
    result.ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    return result;
}

void track_update(PlacementTrack& track, std::span<const Model* const> models, std::span<const PlacedInstance> instances,
                  int refresh)
{
    if (refresh < 1 || refresh > 1000000) throw Error("placement: track_refresh", "must lie in 1..1000000");
    const std::uint64_t frame = track.frame == 0 ? 0 : track.frame - 1;
    std::vector<std::pair<Box, std::uint64_t>> followed;
    std::vector<Box> found;
    for (const PlacedInstance& instance : instances) {
        if (instance.model >= models.size() || !models[instance.model])
            throw Error("placement", "an instance names model " + std::to_string(instance.model) + " of " +
                                         std::to_string(models.size()));
        found.push_back(placed_model_box(*models[instance.model], instance.transform));
        followed.emplace_back(found.back(), frame);
    }
    // An instance not found again is followed where it was last seen, for a while.
    for (const auto& entry : track.followed)
        if (!intersects_any(entry.first, found) && frame - entry.second < std::uint64_t(refresh))
            followed.push_back(entry);
    track.followed = std::move(followed);
}

std::string to_json(const PlacementParams& params)
{
    const nlohmann::ordered_json out = {{"strategy", to_string(params.strategy)},
                                        {"levels", params.levels},
                                        {"fovea_margin", shortest_double(params.fovea_margin)},
                                        {"outer_margin", shortest_double(params.outer_margin)},
                                        {"outer_density_factor", shortest_double(params.outer_density_factor)},
                                        {"voxel", shortest_double(params.voxel)},
                                        {"plane_distance", shortest_double(params.plane_distance)},
                                        {"max_planes", params.max_planes},
                                        {"min_plane_fraction", shortest_double(params.min_plane_fraction)},
                                        {"min_plane_span", shortest_double(params.min_plane_span)},
                                        {"plane_iterations", params.plane_iterations},
                                        {"cluster_gap", shortest_double(params.cluster_gap)},
                                        {"min_cluster_voxels", params.min_cluster_voxels},
                                        {"min_cluster_share", shortest_double(params.min_cluster_share)},
                                        {"max_cluster_factor", shortest_double(params.max_cluster_factor)},
                                        {"max_fovea_fraction", shortest_double(params.max_fovea_fraction)},
                                        {"coarse_factor", shortest_double(params.coarse_factor)},
                                        {"coarse_hypotheses", params.coarse_hypotheses},
                                        {"grid_cell", shortest_double(params.grid_cell)},
                                        {"track_refresh", params.track_refresh},
                                        {"track_margin", shortest_double(params.track_margin)}};
    return detail::json_text(out);
}

std::string to_json(const PlacementResult& result)
{
    const nlohmann::ordered_json out = {
        {"strategy", to_string(result.strategy)},
        {"structures", result.config.structures.size()},
        {"planes", result.planes},
        {"clusters", result.clusters},
        {"clusters_too_large", result.clusters_too_large},
        {"followed", result.followed},
        {"searched", result.searched},
        {"hypotheses", result.hypotheses},
        {"fovea_fraction", result.fovea_fraction},
        {"ms", result.ms},
        {"fallback", result.fallback.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(result.fallback)}};
    return detail::json_text(out);
}

std::string summary(const PlacementResult& result)
{
    auto count = [](std::size_t n, const char* one, const char* many) {
        return std::to_string(n) + " " + (n == 1 ? one : many);
    };
    std::string details;
    switch (result.strategy) {
    case PlacementStrategy::segments:
    case PlacementStrategy::track:
        details = count(result.planes, "plane", "planes") + ", " + count(result.clusters, "cluster", "clusters") +
                  ", " + std::to_string(result.clusters_too_large) + " longer than an object";
        if (result.strategy == PlacementStrategy::track)
            details = std::to_string(result.followed) + " followed" +
                      (result.searched ? ", searched: " + details : std::string(", no search"));
        break;
    case PlacementStrategy::coarse: details = count(result.hypotheses, "hypothesis", "hypotheses"); break;
    case PlacementStrategy::grid:
    case PlacementStrategy::oracle: break;
    }
    char ms[32];
    std::snprintf(ms, sizeof ms, "%.1f ms", result.ms);
    return std::string(to_string(result.strategy)) + ": " +
           count(result.config.structures.size(), "structure", "structures") +
           (details.empty() ? "" : " (" + details + ")") + ", " + ms;
}

}  // namespace mfpc
