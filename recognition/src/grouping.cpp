#include "mfpc/recognition/grouping.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <string>

#include <Eigen/Geometry>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/slot_table.hpp"

namespace mfpc {
namespace {

void check_inputs(const Features& model, const Features& scene, const std::vector<Correspondence>& correspondences)
{
    for (const auto& c : correspondences)
        if (c.model >= model.size() || c.scene >= scene.size())
            throw Error("grouping", "a correspondence refers to keypoint " + std::to_string(c.model) + " / " +
                                        std::to_string(c.scene) + " beyond the model's " +
                                        std::to_string(model.size()) + " / scene's " + std::to_string(scene.size()));
}

// The rigid least-squares pose (Umeyama, no scaling) taking the columns of `from` onto `to`.
template <class Columns>
Pose umeyama_pose(const Columns& from, const Columns& to)
{
    const Eigen::Matrix4d m = Eigen::umeyama(from, to, false);
    Pose pose = Pose::Identity();
    pose.linear() = m.topLeftCorner<3, 3>().cast<float>();
    pose.translation() = m.topRightCorner<3, 1>().cast<float>();
    return pose;
}

// An orthonormal frame of the plane through three points: the first axis along the first edge,
// the third along the normal. False when the points are collinear.
bool plane_frame(const Eigen::Vector3d (&p)[3], Eigen::Matrix3d& frame)
{
    const Eigen::Vector3d edge = p[1] - p[0];
    const Eigen::Vector3d normal = edge.cross(p[2] - p[0]);
    if (!(normal.squaredNorm() > 0.0)) return false;
    frame.col(0) = edge.normalized();
    frame.col(2) = normal.normalized();
    frame.col(1) = frame.col(2).cross(frame.col(0));
    return true;
}

// fit_rigid of three pairs, in closed form: RANSAC fits thousands of samples, and the SVD was most
// of its time. Three points span a plane, so with the planes' frames E and F (each with its normal
// along its own triangle's vertex order) only the 2x2 block Q of G = F^T R E enters the sum to
// maximize: sum b_i^T R a_i = tr(Q M), M = sum alpha_i beta_i^T in plane coordinates. Q, a block of
// a rotation, gives at most M's nuclear norm, which the 2x2 rotation along (m00 + m11, m01 - m10)
// reaches when det M > 0; and det M is three times the product of the centred triangles' signed
// areas (Cauchy-Binet), positive in these frames. So G is that rotation about the normal: the
// same pose as Umeyama's SVD, to rounding.
Pose fit_sample(const Point (&from)[3], const Point (&to)[3])
{
    Eigen::Vector3d a[3], b[3];
    Eigen::Vector3d a_mean = Eigen::Vector3d::Zero(), b_mean = Eigen::Vector3d::Zero();
    for (int i = 0; i < 3; ++i) {
        a[i] = from[i].cast<double>();
        b[i] = to[i].cast<double>();
        a_mean += a[i];
        b_mean += b[i];
    }
    a_mean /= 3.0;
    b_mean /= 3.0;
    Eigen::Matrix3d e, f;
    Eigen::Vector2d turn = Eigen::Vector2d::Zero();  // (m00 + m11, m01 - m10)
    const bool planes = plane_frame(a, e) && plane_frame(b, f);
    if (planes) {
        for (int i = 0; i < 3; ++i) {
            const Eigen::Vector2d alpha = e.leftCols<2>().transpose() * (a[i] - a_mean);
            const Eigen::Vector2d beta = f.leftCols<2>().transpose() * (b[i] - b_mean);
            turn += Eigen::Vector2d(alpha.dot(beta), alpha.x() * beta.y() - alpha.y() * beta.x());
        }
    }
    // Collinear scene points: the SVD's answer, whatever it is.
    if (!planes || !(turn.squaredNorm() > 0.0)) {
        Eigen::Matrix3d from_columns, to_columns;
        for (int i = 0; i < 3; ++i) {
            from_columns.col(i) = a[i];
            to_columns.col(i) = b[i];
        }
        return umeyama_pose(from_columns, to_columns);
    }
    const Eigen::Vector2d u = turn.normalized();
    Eigen::Matrix3d g;
    g << u.x(), -u.y(), 0.0, u.y(), u.x(), 0.0, 0.0, 0.0, 1.0;
    const Eigen::Matrix3d rotation = f * g * e.transpose();
    Pose pose = Pose::Identity();
    pose.linear() = rotation.cast<float>();
    pose.translation() = (b_mean - rotation * a_mean).cast<float>();
    return pose;
}

// RANSAC over a cluster's correspondences (three at a time, a generator seeded by the cluster's
// rank, so the result does not depend on threads or runs), then a least-squares fit on the largest
// inlier set. Returns false when fewer than three correspondences agree. `pool` lists the
// cluster's correspondences the samples are drawn from (all of them for the first pose); the
// inliers are counted over the whole cluster.
bool fit_pose(const Features& model, const Features& scene, const std::vector<Correspondence>& cluster,
              const std::vector<std::uint32_t>& pool, const GroupingParams& params, std::uint32_t seed,
              Pose& pose_out, std::vector<std::uint32_t>& best)
{
    if (pool.size() < 3) return false;
    const float inlier2 = params.ransac_distance * params.ransac_distance;
    // Every correspondence is written and only inliers are kept (the count moves past them): the
    // branch it replaces went either way in clutter and was mispredicted often.
    auto inliers_of = [&](const Pose& pose, const std::vector<std::uint32_t>& among,
                          std::vector<std::uint32_t>& inliers) {
        inliers.resize(among.size());
        std::size_t count = 0;
        for (const std::uint32_t i : among) {
            const Point moved = pose * model.keypoints[cluster[i].model];
            inliers[count] = i;
            count += (moved - scene.keypoints[cluster[i].scene]).squaredNorm() <= inlier2;
        }
        inliers.resize(count);
    };
    std::mt19937 rng(seed);
    std::uniform_int_distribution<std::uint32_t> pick(0, std::uint32_t(pool.size() - 1));
    std::vector<std::uint32_t> current;
    best.clear();
    const int iterations = pool.size() == 3 ? 1 : params.ransac_iterations;
    for (int it = 0; it < iterations; ++it) {
        std::uint32_t a = 0, b = 1, c = 2;
        if (pool.size() > 3) {
            a = pick(rng);
            do b = pick(rng); while (b == a);
            do c = pick(rng); while (c == a || c == b);
        }
        const std::uint32_t sample[3] = {pool[a], pool[b], pool[c]};
        Point from[3], to[3];
        for (int j = 0; j < 3; ++j) {
            from[j] = model.keypoints[cluster[sample[j]].model];
            to[j] = scene.keypoints[cluster[sample[j]].scene];
        }
        // A degenerate (nearly collinear) sample fixes no rotation.
        if ((from[1] - from[0]).cross(from[2] - from[0]).norm() < 1e-6f) continue;
        inliers_of(fit_sample(from, to), pool, current);
        if (current.size() > best.size()) best = current;
        if (best.size() == pool.size()) break;
    }
    if (best.size() < 3) return false;
    std::vector<std::uint32_t> all(cluster.size());
    std::iota(all.begin(), all.end(), 0u);
    // Least squares on the inliers, then once more on the inliers of that pose.
    std::vector<Point> from, to;
    for (int round = 0; round < 2; ++round) {
        from.clear();
        to.clear();
        for (std::uint32_t i : best) {
            from.push_back(model.keypoints[cluster[i].model]);
            to.push_back(scene.keypoints[cluster[i].scene]);
        }
        pose_out = fit_rigid(from, to);
        inliers_of(pose_out, all, current);
        if (current.size() < 3) return false;
        best = current;
    }
    return true;
}

// Up to `modes` poses of one cluster, appended to `out`. A nearly symmetric object (a mug about its
// axis, a box or a square carton by a quarter or half turn) draws votes at one place from several
// poses, so a Hough cluster is often multimodal, and the mode with the most inliers is not always
// the true one. Each further mode is fitted on the correspondences no earlier mode took; it is kept
// when it has at least `mode_inlier_ratio` of the first mode's inliers and is turned at least
// `mode_min_angle` from every earlier one, with the cluster's votes scaled by that ratio.
// Verification chooses among them. Each mode draws from its own generator, derived from `seed`.
void fit_instances(const Features& model, const Features& scene, const std::vector<Correspondence>& cluster,
                   const GroupingParams& params, int modes, std::uint32_t seed, float votes,
                   std::vector<Instance>& out)
{
    const std::size_t first = out.size();
    std::vector<std::uint32_t> pool(cluster.size());
    std::iota(pool.begin(), pool.end(), 0u);
    std::vector<char> taken(cluster.size(), 0);
    std::size_t first_inliers = 0;
    for (int mode = 0; mode < modes; ++mode) {
        Pose pose;
        std::vector<std::uint32_t> inliers;
        // A multiplicative-hash stride keeps the modes' generators apart from the next cluster's.
        const std::uint32_t mode_seed = seed + 0x9E3779B9u * std::uint32_t(mode);
        if (!fit_pose(model, scene, cluster, pool, params, mode_seed, pose, inliers)) break;
        if (mode == 0) {
            first_inliers = inliers.size();
        } else {
            if (float(inliers.size()) < params.mode_inlier_ratio * float(first_inliers)) break;
            const bool distinct = std::none_of(out.begin() + std::ptrdiff_t(first), out.end(), [&](const Instance& o) {
                return rotation_error_deg(o.transform, pose) < params.mode_min_angle;
            });
            if (!distinct) break;
        }
        Instance instance;
        instance.transform = pose;
        instance.votes = votes * float(inliers.size()) / float(first_inliers);
        for (const std::uint32_t i : inliers) {
            instance.correspondences.push_back(cluster[i]);
            taken[i] = 1;
        }
        out.push_back(std::move(instance));
        std::erase_if(pool, [&](std::uint32_t i) { return taken[i] != 0; });
    }
}

}  // namespace

Pose fit_rigid(std::span<const Point> from, std::span<const Point> to)
{
    if (from.size() != to.size() || from.size() < 3) throw Error("fit_rigid", "needs at least three point pairs");
    if (from.size() == 3) return fit_sample({from[0], from[1], from[2]}, {to[0], to[1], to[2]});
    Eigen::Matrix3Xd a(3, from.size()), b(3, to.size());
    for (std::size_t i = 0; i < from.size(); ++i) {
        a.col(Eigen::Index(i)) = from[i].cast<double>();
        b.col(Eigen::Index(i)) = to[i].cast<double>();
    }
    return umeyama_pose(a, b);
}

std::vector<Instance> hough_grouping(const Features& model, const Features& scene,
                                     const std::vector<Correspondence>& correspondences, const GroupingParams& params)
{
    check_inputs(model, scene, correspondences);
    if (!(params.hough_bin > 0.0f)) throw Error("hough_grouping", "hough_bin must be positive");
    if (correspondences.empty() || model.size() == 0) return {};

    // The model's reference point, and each model keypoint's vote for it in its own frame.
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const auto& p : model.keypoints) centroid += p.cast<double>();
    const Point reference = (centroid / double(model.size())).cast<float>();

    // Scene votes: the model vote carried through the scene keypoint's frame.
    std::vector<Point> votes(correspondences.size());
    for (std::size_t i = 0; i < correspondences.size(); ++i) {
        const auto& c = correspondences[i];
        const Point local = model.frames[c.model] * (reference - model.keypoints[c.model]);
        votes[i] = scene.frames[c.scene].transpose() * local + scene.keypoints[c.scene];
    }

    // Interpolated voting into a sparse 3D histogram: bin centres at (i + 0.5) * bin; each vote
    // spreads over the 8 nearest centres with trilinear weights and is a voter of each. Bins are
    // numbered in first-touch order (the scan order below) and found by their packed key (63 bits)
    // in a SlotTable; the (bin, voter) pairs are kept flat and grouped by bin only for the
    // peaks. A node-based map with a voter list per bin spent most of the voting allocating.
    auto key_of = [](const Eigen::Vector3i& b) {
        return (std::uint64_t(std::uint32_t(b.x()) & 0x1FFFFF) << 42) | (std::uint64_t(std::uint32_t(b.y()) & 0x1FFFFF) << 21) |
               std::uint64_t(std::uint32_t(b.z()) & 0x1FFFFF);
    };
    detail::SlotTable table(votes.size() * 2);  // a guess: the votes share most of their bins
    std::vector<float> values;            // per bin
    std::vector<Eigen::Vector3i> coords;  // per bin
    std::vector<std::pair<std::uint32_t, std::uint32_t>> voted;  // (bin, voter), in voting order
    const float inverse = 1.0f / params.hough_bin;
    for (std::uint32_t i = 0; i < votes.size(); ++i) {
        if (!votes[i].allFinite()) continue;
        const Eigen::Vector3f u = votes[i] * inverse - Eigen::Vector3f::Constant(0.5f);
        const Eigen::Vector3f base = u.array().floor();
        const Eigen::Vector3f frac = u - base;
        for (int corner = 0; corner < 8; ++corner) {
            const Eigen::Vector3i offset((corner >> 0) & 1, (corner >> 1) & 1, (corner >> 2) & 1);
            float weight = 1.0f;
            for (int axis = 0; axis < 3; ++axis) weight *= offset[axis] ? frac[axis] : 1.0f - frac[axis];
            if (weight <= 0.0f) continue;
            const Eigen::Vector3i b = base.cast<int>() + offset;
            const auto [bin, inserted] = table.find_or_add(key_of(b), std::uint32_t(values.size()));
            if (inserted) {
                values.push_back(0.0f);
                coords.push_back(b);
            }
            values[bin] += weight;
            voted.emplace_back(bin, i);
        }
    }

    // Local maxima (>= every neighbour, and > the neighbours scanned before, so a plateau yields
    // one maximum) with at least hough_threshold votes.
    struct Peak {
        float value;
        std::uint32_t bin;
    };
    std::vector<Peak> peaks;
    for (std::uint32_t k = 0; k < values.size(); ++k) {
        const float value = values[k];
        if (value < params.hough_threshold) continue;
        bool is_max = true;
        for (int dz = -1; dz <= 1 && is_max; ++dz)
            for (int dy = -1; dy <= 1 && is_max; ++dy)
                for (int dx = -1; dx <= 1 && is_max; ++dx) {
                    if (!dx && !dy && !dz) continue;
                    const std::uint32_t other = table.find(key_of(coords[k] + Eigen::Vector3i(dx, dy, dz)));
                    if (other == detail::SlotTable::none) continue;
                    if (values[other] > value) is_max = false;
                    else if (values[other] == value && std::make_tuple(dz, dy, dx) < std::make_tuple(0, 0, 0))
                        is_max = false;
                }
        if (is_max) peaks.push_back({value, k});
    }
    std::sort(peaks.begin(), peaks.end(), [](const Peak& a, const Peak& b) {
        return a.value != b.value ? a.value > b.value : a.bin < b.bin;
    });
    // The voters of each peak, in voting order.
    std::vector<std::uint32_t> peak_of(values.size(), std::uint32_t(peaks.size()));
    for (std::uint32_t rank = 0; rank < peaks.size(); ++rank) peak_of[peaks[rank].bin] = rank;
    std::vector<std::vector<std::uint32_t>> voters(peaks.size());
    for (const auto& [bin, voter] : voted)
        if (peak_of[bin] < peaks.size()) voters[peak_of[bin]].push_back(voter);

    // The clusters are fitted in parallel; each fit draws from its own generator, seeded by its
    // rank, so the instances do not depend on the threads.
    std::vector<std::vector<Instance>> fitted(peaks.size());
    tbb::parallel_for(std::size_t(0), peaks.size(), [&](std::size_t rank) {
        std::vector<Correspondence> cluster;
        for (std::uint32_t v : voters[rank]) cluster.push_back(correspondences[v]);
        fit_instances(model, scene, cluster, params, params.ransac_modes, std::uint32_t(rank + 1), peaks[rank].value,
                      fitted[rank]);
    });
    std::vector<Instance> instances;
    for (std::size_t rank = 0; rank < peaks.size(); ++rank)
        for (Instance& instance : fitted[rank]) instances.push_back(std::move(instance));
    std::stable_sort(instances.begin(), instances.end(),
                     [](const Instance& a, const Instance& b) { return a.votes > b.votes; });
    return instances;
}

std::vector<Instance> gc_grouping(const Features& model, const Features& scene,
                                  const std::vector<Correspondence>& correspondences, const GroupingParams& params)
{
    check_inputs(model, scene, correspondences);
    if (!(params.gc_size > 0.0f)) throw Error("gc_grouping", "gc_size must be positive");
    // Seeds in order of descriptor distance (best first), as PCL's GeometricConsistencyGrouping.
    std::vector<std::uint32_t> order(correspondences.size());
    for (std::uint32_t i = 0; i < order.size(); ++i) order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
        return correspondences[a].distance < correspondences[b].distance;
    });
    std::vector<std::uint8_t> taken(correspondences.size(), 0);
    std::vector<Instance> instances;
    std::uint32_t rank = 0;
    for (std::uint32_t seed : order) {
        if (taken[seed]) continue;
        std::vector<std::uint32_t> members{seed};
        for (std::uint32_t j : order) {
            if (j == seed || taken[j]) continue;
            const auto& cj = correspondences[j];
            bool consistent = true;
            for (std::uint32_t m : members) {
                const auto& cm = correspondences[m];
                const float model_distance = (model.keypoints[cm.model] - model.keypoints[cj.model]).norm();
                const float scene_distance = (scene.keypoints[cm.scene] - scene.keypoints[cj.scene]).norm();
                if (std::abs(model_distance - scene_distance) > params.gc_size) {
                    consistent = false;
                    break;
                }
            }
            if (consistent) members.push_back(j);
        }
        if (int(members.size()) < params.gc_threshold) continue;
        for (std::uint32_t m : members) taken[m] = 1;
        std::vector<Correspondence> cluster;
        for (std::uint32_t m : members) cluster.push_back(correspondences[m]);
        // Every member agrees with every other on its distances, so the cluster holds one pose.
        fit_instances(model, scene, cluster, params, 1, ++rank, float(members.size()), instances);
    }
    std::stable_sort(instances.begin(), instances.end(),
                     [](const Instance& a, const Instance& b) { return a.votes > b.votes; });
    return instances;
}

}  // namespace mfpc
