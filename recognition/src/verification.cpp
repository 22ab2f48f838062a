#include "mfpc/recognition/verification.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "mfpc/core/error.hpp"
#include "mfpc/index/nearest_neighbors.hpp"
#include "mfpc/kernels/uniform_sampling.hpp"

namespace mfpc {
namespace {

// Whether a model point placed at p (camera frame) by `pose` turns its surface to the sensor, less
// than acos(min_facing_cos) from the ray; a point without a normal (a degenerate neighbourhood)
// gives no evidence either way.
bool faces_camera(const Pose& pose, const Point& p, const Point& normal, float min_facing_cos)
{
    return normal.allFinite() && (pose.linear() * normal).dot(-p) > min_facing_cos * normal.norm() * p.norm();
}

// The model's normals must be one per point; `where` names the caller in the error.
void check_model_normals(const char* where, std::span<const Point> points, std::span<const Point> normals)
{
    if (normals.size() != points.size())
        throw Error(where, "the model has " + std::to_string(normals.size()) + " normals for " +
                               std::to_string(points.size()) + " points");
}

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
    Eigen::Vector3d mean() const { return sum / double(count); }
    Eigen::Matrix3d covariance() const { return products / double(count) - mean() * mean().transpose(); }
    float thickness() const
    {
        if (count < 3) return 0.0f;
        const double smallest =
            Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance(), Eigen::EigenvaluesOnly).eigenvalues()[0];
        return float(std::sqrt(std::max(smallest, 0.0)));
    }
};

struct Fit {
    Pose pose;
    float rmse = 0.0f;
};

// Lookup buffers, one entry per (thinned) model point, shared by the steps of every hypothesis.
struct Scratch {
    std::vector<Point> placed;  // the model points where the pose being tested puts them
    std::vector<std::uint32_t> nearest;
    std::vector<float> squared_distances;
    std::vector<std::uint8_t> wanted;
    // The organized scene's batch search: the wanted points, their numbers and what it found.
    std::vector<Point> queries;
    std::vector<std::uint32_t> asked;
    std::vector<std::uint32_t> found;
    std::vector<float> found_squared;
    explicit Scratch(std::size_t points) : placed(points), nearest(points), squared_distances(points), wanted(points) {}
};

void place(const Pose& pose, std::span<const Point> model, std::span<Point> placed)
{
    for (std::size_t i = 0; i < model.size(); ++i) placed[i] = pose * model[i];
}

// The nearest scene point within `radius` of each of scratch.placed that `wanted` marks (all when
// empty), the searches in parallel; misses and unwanted points get no_match. Written per point, so
// what is made of them is the same at any thread count.
constexpr std::uint32_t no_match = std::numeric_limits<std::uint32_t>::max();
void nearest_scene_points(std::span<const std::uint8_t> wanted, const SceneEvidence& scene, float radius,
                          Scratch& scratch)
{
    if (scene.organized) {
        // The wanted points side by side for the batch search, then back in place.
        scratch.queries.clear();
        scratch.asked.clear();
        for (std::size_t i = 0; i < scratch.placed.size(); ++i)
            if (wanted.empty() || wanted[i]) {
                scratch.queries.push_back(scratch.placed[i]);
                scratch.asked.push_back(std::uint32_t(i));
            }
        scratch.found.resize(scratch.queries.size());
        scratch.found_squared.resize(scratch.queries.size());
        scene.organized->nearest_batch(scratch.queries, radius, scratch.found, scratch.found_squared);
        std::fill(scratch.nearest.begin(), scratch.nearest.end(), no_match);
        for (std::size_t q = 0; q < scratch.asked.size(); ++q)
            if (scratch.found[q] != OrganizedNeighbors::no_point) {
                scratch.nearest[scratch.asked[q]] = scratch.found[q];
                scratch.squared_distances[scratch.asked[q]] = scratch.found_squared[q];
            }
        return;
    }
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, scratch.placed.size(), 128), [&](const auto& range) {
        for (std::size_t i = range.begin(); i < range.end(); ++i)
            if ((!wanted.empty() && !wanted[i]) ||
                !scene.grid->nearest(scratch.placed[i], radius, scratch.nearest[i], scratch.squared_distances[i]))
                scratch.nearest[i] = no_match;
    });
}

// Two solid objects cannot share space: a placed model with merge_overlap of its points within
// merge_distance of another's is the same object posed twice (a near-symmetric carton turned half
// a turn, or slid along its own face).
bool overlaps(std::span<const Point> placed_points, const NeighborGrid& other, const VerifyParams& verify)
{
    if (placed_points.empty()) return false;
    const std::size_t close = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, placed_points.size(), 128), std::size_t(0),
        [&](const auto& range, std::size_t count) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) {
                std::uint32_t index = 0;
                float d2 = 0.0f;
                if (other.nearest(placed_points[i], verify.merge_distance, index, d2)) ++count;
            }
            return count;
        },
        std::plus<>());
    return float(close) >= verify.merge_overlap * float(placed_points.size());
}

// The pixel of the depth image that p (camera frame) projects to; none without a camera, behind
// the camera or off the image.
constexpr std::size_t no_pixel = std::numeric_limits<std::size_t>::max();
std::size_t pixel_of(const SceneEvidence& scene, const Point& p)
{
    if (!scene.camera || !(p.z() > 0.0f)) return no_pixel;
    const Camera& c = *scene.camera;
    const long u = std::lround(c.fx * p.x() / p.z() + c.cx);
    const long v = std::lround(c.fy * p.y() / p.z() + c.cy);
    if (u < 0 || v < 0 || u >= long(c.width) || v >= long(c.height)) return no_pixel;
    return std::size_t(v) * c.width + std::size_t(u);
}

// The depth the sensor observed through p's pixel; NaN where there is none or it had no return.
float observed_depth(const SceneEvidence& scene, const Point& p)
{
    const std::size_t pixel = pixel_of(scene, p);
    return pixel == no_pixel ? std::numeric_limits<float>::quiet_NaN() : scene.depth[pixel];
}

// The nearest depth observed in a pixel and the 8 around it (no returns skipped).
float nearest_depth_around(const SceneEvidence& scene, std::size_t pixel)
{
    const Camera& c = *scene.camera;
    const std::size_t u = pixel % c.width, v = pixel / c.width;
    float nearest = scene.depth[pixel];
    for (std::size_t y = v > 0 ? v - 1 : 0; y <= std::min<std::size_t>(v + 1, c.height - 1); ++y)
        for (std::size_t x = u > 0 ? u - 1 : 0; x <= std::min<std::size_t>(u + 1, c.width - 1); ++x)
            nearest = std::fmin(nearest, scene.depth[y * c.width + x]);
    return nearest;
}

// The facing model points that the model itself hides from the sensor at a pose (a mug's inside
// behind its front wall). Each placed point stands for a disc of `radius` in its tangent plane (the
// thinned model's spacing, so that the discs close the surface); a facing point is hidden when the
// ray to it crosses another point's disc more than three radii before reaching it. Near an edge of a
// convex model a disc reaches past the edge over the face beside it, and the ray to a point on
// that face crosses it up to about three radii early: the margin must be that, and only hollows
// deeper count. The discs are bucketed by where they project, in coordinates x/z and y/z,
// so that each point asks only the discs over it. No camera is needed: the sensor is the origin,
// as for faces_camera.
struct SelfOcclusion {
    std::vector<Point> normals;  // placed
    struct Span {
        long x0, x1, y0, y1;  // the cells a disc may cover, inclusive
    };
    std::vector<Span> spans;  // per point; unused for the points left out
    std::vector<std::uint32_t> first, cursor, discs;  // cell c's discs: discs[first[c] .. first[c + 1])
};
void hidden_by_model(std::span<const Point> placed, std::span<const Point> model_normals, const Pose& pose,
                     std::span<const std::uint8_t> facing, float radius, SelfOcclusion& work,
                     std::vector<std::uint8_t>& hidden)
{
    const float margin = 3.0f * radius;
    const std::size_t n = placed.size();
    hidden.assign(n, 0);
    if (!(radius > 0.0f)) return;
    // Points closer to the sensor than a few radii are left out: their discs would cover the view.
    const float nearest_allowed = 2.0f * radius;
    work.normals.resize(n);
    for (std::size_t i = 0; i < n; ++i) work.normals[i] = pose.linear() * model_normals[i];
    auto usable = [&](std::size_t i) { return placed[i].z() > nearest_allowed && work.normals[i].allFinite(); };
    float lowest_z = std::numeric_limits<float>::infinity();
    float a_min = lowest_z, b_min = lowest_z, a_max = -lowest_z, b_max = -lowest_z;
    for (std::size_t i = 0; i < n; ++i) {
        if (!usable(i)) continue;
        const Point& p = placed[i];
        lowest_z = std::min(lowest_z, p.z());
        a_min = std::min(a_min, p.x() / p.z());
        a_max = std::max(a_max, p.x() / p.z());
        b_min = std::min(b_min, p.y() / p.z());
        b_max = std::max(b_max, p.y() / p.z());
    }
    if (!std::isfinite(lowest_z)) return;
    // Cells about a disc's projection across at the nearest point; coarser when that would make
    // more cells than a few per point, or the discs cover too many (a model far off the axis, where
    // x/z changes fast): coarser cells only cost more discs asked per point.
    const float width = a_max - a_min, height = b_max - b_min;
    const float most_cells = 4.0f * float(n) + 64.0f;
    float cell = radius / lowest_z;
    if ((width / cell + 1.0f) * (height / cell + 1.0f) > most_cells)
        cell = std::max(width, height) / std::sqrt(most_cells) + std::numeric_limits<float>::min();
    long columns = 0, rows = 0;
    float a0 = 0.0f, b0 = 0.0f;
    auto column = [&](float a) { return std::clamp(long((a - a0) / cell), 0L, columns - 1); };
    auto row = [&](float b) { return std::clamp(long((b - b0) / cell), 0L, rows - 1); };
    work.spans.resize(n);
    for (;;) {
        a0 = a_min - cell;
        b0 = b_min - cell;
        columns = long((width + 2.0f * cell) / cell) + 2;
        rows = long((height + 2.0f * cell) / cell) + 2;
        double entries = 0.0;
        for (std::size_t i = 0; i < n; ++i) {
            if (!usable(i)) continue;
            const Point& q = placed[i];
            const float a = q.x() / q.z(), b = q.y() / q.z();
            const float e = radius * (1.0f + std::abs(a) + std::abs(b)) / (q.z() - radius);
            const SelfOcclusion::Span span{column(a - e), column(a + e), row(b - e), row(b + e)};
            work.spans[i] = span;
            entries += double(span.x1 - span.x0 + 1) * double(span.y1 - span.y0 + 1);
        }
        if (entries <= 64.0 * double(n) + 1024.0) break;
        cell *= 2.0f;
    }
    // Counting sort of the discs into the cells they may cover.
    work.first.assign(std::size_t(columns * rows) + 1, 0);
    for (std::size_t i = 0; i < n; ++i)
        if (usable(i))
            for (long y = work.spans[i].y0; y <= work.spans[i].y1; ++y)
                for (long x = work.spans[i].x0; x <= work.spans[i].x1; ++x) ++work.first[std::size_t(y * columns + x) + 1];
    for (std::size_t c = 1; c < work.first.size(); ++c) work.first[c] += work.first[c - 1];
    work.cursor.assign(work.first.begin(), work.first.end() - 1);
    work.discs.resize(work.first.back());
    for (std::size_t i = 0; i < n; ++i)
        if (usable(i))
            for (long y = work.spans[i].y0; y <= work.spans[i].y1; ++y)
                for (long x = work.spans[i].x0; x <= work.spans[i].x1; ++x)
                    work.discs[work.cursor[std::size_t(y * columns + x)]++] = std::uint32_t(i);
    // Each point's rays against the discs over it, in parallel: the rest of refine_and_test's
    // searches are, and this alone was a serial tenth of verification.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 256), [&](const auto& range) {
        for (std::size_t i = range.begin(); i < range.end(); ++i) {
            if (!facing[i] || !usable(i)) continue;
            const Point& p = placed[i];
            const std::size_t c = std::size_t(row(p.y() / p.z()) * columns + column(p.x() / p.z()));
            for (std::uint32_t k = work.first[c]; k < work.first[c + 1] && !hidden[i]; ++k) {
                const std::uint32_t j = work.discs[k];
                if (j == i) continue;
                const Point& normal = work.normals[j];
                const float across = normal.dot(p);
                if (std::abs(across) < 1e-12f) continue;  // the ray runs along the disc
                const float s = normal.dot(placed[j]) / across;
                const Point hit = s * p;
                hidden[i] = s > 0.0f && hit.z() < p.z() - margin && (hit - placed[j]).squaredNorm() <= radius * radius;
            }
        }
    });
}

// The placed model points the sensor would see at `pose`, were nothing else in front of them:
// facing it (faces_camera) and not hidden by the model itself (hidden_by_model, discs of `spacing`).
void seen_by_sensor(std::span<const Point> placed, std::span<const Point> normals, const Pose& pose,
                    float min_facing_cos, float spacing, SelfOcclusion& work, std::vector<std::uint8_t>& hidden,
                    std::span<std::uint8_t> seen)
{
    for (std::size_t i = 0; i < placed.size(); ++i) seen[i] = faces_camera(pose, placed[i], normals[i], min_facing_cos);
    hidden_by_model(placed, normals, pose, seen, spacing, work, hidden);
    for (std::size_t i = 0; i < placed.size(); ++i) seen[i] = seen[i] && !hidden[i];
}

// What ICP pairs with the scene: the model points the sensor would see at the pose being refined.
struct IcpView {
    std::span<const Point> normals;  // one per (thinned) model point
    float min_facing_cos = 0.0f;     // VerifyParams::min_facing_cos
    float disc_radius = 0.0f;        // the points' spacing, for hidden_by_model
};

// ICP (point to point) of the model points the sensor would see at the current pose: facing it and
// not hidden by the model itself. Were every point paired, the hidden ones would pair with the
// nearest seen surface and pull the pose toward the sensor: a mug's inner front wall, behind its
// outer one, pairs with that outer wall, and its outer back wall with the inner back wall seen over
// the rim. From their true poses, the synthetic set's mugs were refined 3-7 mm up and toward the
// sensor, enough for their rim to refute them. The seen points are found again every
// visibility_period iterations: an iteration moves the pose by millimetres, which changes few of
// them, and finding them costs about two iterations (every iteration, on the 40 kinect scenes:
// verification's median 410 ms against 277, as many instances found).
constexpr int visibility_period = 5;
Fit icp(const Pose& start, std::span<const Point> model, const IcpView& view, const SceneEvidence& scene,
        const RefineParams& params, Scratch& scratch, SelfOcclusion& occlusion)
{
    Fit fit{start, 0.0f};
    std::vector<Point> from, to;
    std::vector<std::uint8_t> seen(model.size()), hidden;
    for (int it = 0; it < params.iterations; ++it) {
        place(fit.pose, model, scratch.placed);
        if (it % visibility_period == 0)
            seen_by_sensor(scratch.placed, view.normals, fit.pose, view.min_facing_cos, view.disc_radius, occlusion,
                           hidden, seen);
        nearest_scene_points(seen, scene, params.max_distance, scratch);
        from.clear();
        to.clear();
        double squared_sum = 0.0;
        for (std::size_t i = 0; i < model.size(); ++i) {
            if (scratch.nearest[i] == no_match) continue;
            from.push_back(scratch.placed[i]);
            to.push_back(scene.points[scratch.nearest[i]]);
            squared_sum += scratch.squared_distances[i];
        }
        if (from.size() < 3) break;
        fit.rmse = float(std::sqrt(squared_sum / double(from.size())));
        const Pose step = fit_rigid(from, to);
        fit.pose = step * fit.pose;
        if (step.translation().norm() < 1e-6f && rotation_error_deg(step, Pose::Identity()) < 1e-4f) break;
    }
    return fit;
}

// The turns of a model about its axes under which it nearly covers itself: the poses an object is
// mistaken for on the body they share (a mug about its axis, told apart only by its handle; a square
// carton by quarter turns, told apart by its gable).
//
// The axes are those of the normals' scatter: for a solid of revolution, its axis (the points' own
// principal axes tilt toward a mug's handle). Each runs through the point nearest the normals'
// lines projected across it (where a solid of revolution's normals all meet its axis), robustly:
// lines passing farther than `tolerance` from the last solution are left out of the next, or a
// mug's handle, whose normals meet on its own centre line, would draw the centre 6 mm toward it.
// A turn is kept when at least `overlap` of the points land within `tolerance` of the whole
// model, but not 98% of them (a symmetry: a bottle about its axis is the same pose), judged on
// at most 256 of the points. The steps (at most 720 a turn) are fine enough that the point farthest
// from the axis moves at most `step_distance` from one to the next (ICP then converges from the
// step nearest the truth); a turn of one step either way is left out (ICP would return from it to
// the pose).
std::vector<Pose> model_turns(std::span<const Point> points, std::span<const Point> normals,
                              std::span<const Point> whole, float tolerance, float overlap, float step_distance)
{
    constexpr float symmetric_overlap = 0.98f;
    constexpr std::size_t judged = 256;
    std::vector<Pose> turns;
    if (points.size() < 3 || whole.empty() || !(step_distance > 0.0f) || !(tolerance > 0.0f)) return turns;
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3d> units(points.size(), Eigen::Vector3d::Zero());  // zero: no normal
    for (std::size_t i = 0; i < points.size(); ++i) {
        centroid += points[i].cast<double>();
        if (normals[i].allFinite() && normals[i].norm() > 0.0f) {
            units[i] = normals[i].cast<double>().normalized();
            scatter += units[i] * units[i].transpose();
        }
    }
    centroid /= double(points.size());
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> axes(scatter);
    const NeighborGrid model_grid(whole, tolerance);
    const std::size_t stride = (points.size() + judged - 1) / judged;
    for (int a = 0; a < 3; ++a) {
        const Eigen::Vector3d axis = axes.eigenvectors().col(a);
        const Eigen::Matrix3d along = axis * axis.transpose();
        Eigen::Vector3d centre = centroid;
        for (int round = 0; round < 4; ++round) {
            Eigen::Matrix3d lhs = along;  // along the axis: the centroid
            Eigen::Vector3d rhs = along * centroid;
            for (std::size_t i = 0; i < points.size(); ++i) {
                const Eigen::Vector3d across = units[i] - along * units[i];
                const double weight = across.squaredNorm();  // how far the normal runs across the axis
                if (weight < 1e-6) continue;
                const Eigen::Vector3d m = across / std::sqrt(weight);
                const Eigen::Matrix3d off_line = Eigen::Matrix3d::Identity() - m * m.transpose() - along;
                const Eigen::Vector3d p = points[i].cast<double>();
                if (round > 0 && (off_line * (centre - p)).norm() > double(tolerance)) continue;
                lhs += weight * off_line;
                rhs += weight * off_line * p;
            }
            const Eigen::Vector3d solved = lhs.ldlt().solve(rhs);
            if (!solved.allFinite()) break;
            centre = solved;
        }
        double radius = 0.0;
        for (const Point& p : points) {
            const Eigen::Vector3d d = p.cast<double>() - centre;
            radius = std::max(radius, (d - along * d).norm());
        }
        const int steps = int(std::min(720.0, std::ceil(2.0 * M_PI * radius / double(step_distance))));
        for (int k = 2; k < steps - 1; ++k) {
            Pose turn = Pose::Identity();
            turn.linear() = Eigen::AngleAxisd(2.0 * M_PI * k / steps, axis).toRotationMatrix().cast<float>();
            turn.translation() = (centre - turn.linear().cast<double>() * centre).cast<float>();
            std::size_t close = 0, asked = 0;
            for (std::size_t i = 0; i < points.size(); i += stride, ++asked) {
                std::uint32_t index = 0;
                float squared = 0.0f;
                close += model_grid.nearest(turn * points[i], tolerance, index, squared);
            }
            const float share = float(close) / float(asked);
            if (share < overlap || share >= symmetric_overlap) continue;
            const float apart = 180.0f / float(steps);  // half a step
            if (std::none_of(turns.begin(), turns.end(),
                             [&](const Pose& t) { return rotation_error_deg(t, turn) < apart; }))
                turns.push_back(turn);
        }
    }
    return turns;
}

// The depth image's pixels whose observed surface the seen model points explain: within `radius` of
// one (a little more than the points' spacing, so that their discs cover the surface between them)
// and within `tolerance` of its tangent plane. The scene's side of the fit, which tells apart two
// poses of one object: a mug turned with its handle behind its body explains the body as well as
// its true pose does, but not the handle the sensor saw (while it has about as many model points
// fitting the scene, its handle out of view no longer counting against it).
std::size_t explained_pixels(const SceneEvidence& scene, std::span<const Point> placed, std::span<const Point> normals,
                             const Pose& pose, std::span<const std::uint8_t> seen, float radius, float tolerance,
                             std::vector<std::uint8_t>& marks, std::vector<std::size_t>& marked)
{
    const Camera& c = *scene.camera;
    marks.resize(std::size_t(c.width) * c.height, 0);
    for (std::size_t pixel : marked) marks[pixel] = 0;
    marked.clear();
    for (std::size_t i = 0; i < placed.size(); ++i) {
        const Point& p = placed[i];
        if (!seen[i] || !(p.z() > radius)) continue;
        const Point n = pose.linear() * normals[i];
        const float u0 = c.fx * p.x() / p.z() + c.cx, v0 = c.fy * p.y() / p.z() + c.cy;
        const float reach_u = c.fx * radius / (p.z() - radius), reach_v = c.fy * radius / (p.z() - radius);
        const long u_lo = std::max(0L, long(std::floor(u0 - reach_u)));
        const long u_hi = std::min(long(c.width) - 1, long(std::ceil(u0 + reach_u)));
        const long v_lo = std::max(0L, long(std::floor(v0 - reach_v)));
        const long v_hi = std::min(long(c.height) - 1, long(std::ceil(v0 + reach_v)));
        for (long v = v_lo; v <= v_hi; ++v)
            for (long u = u_lo; u <= u_hi; ++u) {
                const std::size_t pixel = std::size_t(v) * c.width + std::size_t(u);
                const float z = scene.depth[pixel];
                if (marks[pixel] || !std::isfinite(z)) continue;
                const Point d = Point((float(u) - c.cx) * z / c.fx, (float(v) - c.cy) * z / c.fy, z) - p;
                if (d.squaredNorm() <= radius * radius && std::abs(d.dot(n)) <= tolerance) {
                    marks[pixel] = 1;
                    marked.push_back(pixel);
                }
            }
    }
    return marked.size();
}

// What the scene says of a pose where another pose of the same object differs from it: the sum of
// the evidence (+1 a point the scene explains, -1 one it contradicts, 0 no say) of its points
// (`placed`) with no point of the other placement (`other`) within `apart`. Two poses sharing a
// body (a mug turned about its axis) differ only in a small part (its handle): counted over the
// whole object, the part is lost in the body's noise, which shifts by a few per cent between two
// refinements of the same body (stereo noise).
long support_where_apart(std::span<const Point> placed, std::span<const std::int8_t> evidence,
                         std::span<const Point> other, float apart)
{
    const NeighborGrid grid(other, apart);
    long support = 0;
    for (std::size_t i = 0; i < placed.size(); ++i) {
        if (evidence[i] == 0) continue;
        std::uint32_t index = 0;
        float squared = 0.0f;
        if (!grid.nearest(placed[i], apart, index, squared)) support += evidence[i];
    }
    return support;
}

// Rim probes: where the model's surface would go on if the object were bigger. Each (thinned)
// model point gets eight probes in its tangent plane, rim_distance away (VerifyParams says why
// that far); a probe with a model point within 0.6 rim_distance lies on the model and is dropped,
// so the probes left run just beyond the model's edges.
struct Probe {
    Point at;              // model frame
    std::uint32_t source;  // the thinned model point it extends
};
std::vector<Probe> rim_probes(std::span<const Point> points, std::span<const Point> normals,
                              std::span<const Point> model_points, float rim_distance)
{
    std::vector<Probe> probes;
    if (points.empty()) return probes;
    // `points` are some of model_points: a probe near one of them is on the model. Each point's
    // neighbours among them, as far as its probes reach, settle most of its probes; the rest ask
    // the whole model. One point's neighbours at a time: unthinned (model_voxel 0), a dense model
    // has thousands each.
    const float on_model = 0.6f * rim_distance;
    const float reach = rim_distance + on_model;
    const NeighborGrid thinned(points, reach);
    std::optional<NeighborGrid> model;
    std::vector<std::uint32_t> neighbours;
    std::vector<float> squared_distances;
    for (std::uint32_t i = 0; i < points.size(); ++i) {
        if (!normals[i].allFinite() || normals[i].squaredNorm() == 0.0f) continue;
        const Eigen::Vector3f n = normals[i].normalized();
        const Eigen::Vector3f a =
            (std::abs(n.x()) < 0.9f ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitY()).cross(n).normalized();
        const Eigen::Vector3f b = n.cross(a);
        thinned.radius_search(points[i], reach, neighbours, squared_distances);
        for (int d = 0; d < 8; ++d) {
            const float angle = float(d) * float(M_PI) / 4.0f;
            const Point at = points[i] + rim_distance * (std::cos(angle) * a + std::sin(angle) * b);
            if (std::any_of(neighbours.begin(), neighbours.end(),
                            [&](std::uint32_t j) { return (points[j] - at).squaredNorm() < on_model * on_model; }))
                continue;
            if (!model) model.emplace(model_points, on_model);
            std::uint32_t index = 0;
            float d2 = 0.0f;
            if (!model->nearest(at, on_model, index, d2)) probes.push_back({at, i});
        }
    }
    return probes;
}

// What the scene shows at the rim probes of the fitting model points (`fitting`: per thinned
// point, not no_match where it fits). Continued: a scene point within inlier_distance of the probe,
// the object's surface going on where this pose ends it (a pose slid along the object's own face,
// or turned on it, explains the part it covers and leaves the rest). Free: the sensor saw past
// the probe, so the object ends there. A probe hidden behind a nearer surface or where the sensor
// had no return tells nothing; without a camera every probe with no scene point counts as free.
struct RimEvidence {
    std::size_t continued = 0;
    std::size_t free = 0;
};
RimEvidence rim_evidence(const Pose& pose, std::span<const Probe> probes, std::span<const std::uint32_t> fitting,
                         const SceneEvidence& scene, const VerifyParams& verify, Scratch& scratch)
{
    RimEvidence evidence;
    for (std::size_t j = 0; j < probes.size(); ++j) {
        scratch.wanted[j] = 0;
        if (fitting[probes[j].source] == no_match) continue;
        const Point q = pose * probes[j].at;
        scratch.placed[j] = q;
        if (scene.camera) {
            const float observed = observed_depth(scene, q);
            if (!std::isfinite(observed) || observed < q.z() - verify.free_space_margin) continue;
            if (observed > q.z() + verify.free_space_margin) {
                ++evidence.free;
                continue;
            }
        }
        scratch.wanted[j] = 1;
    }
    nearest_scene_points(scratch.wanted, scene, verify.inlier_distance, scratch);
    for (std::size_t j = 0; j < probes.size(); ++j)
        if (scratch.wanted[j]) {
            if (scratch.nearest[j] != no_match) ++evidence.continued;
            else if (!scene.camera) ++evidence.free;
        }
    return evidence;
}

// Each pixel's observed depth, NaN where the sensor had no return.
std::vector<float> depth_image(const PointCloud& scene)
{
    std::vector<float> depth(scene.source_size(), std::numeric_limits<float>::quiet_NaN());
    for (std::size_t i = 0; i < scene.size(); ++i) depth[scene.source_position(i)] = scene.points[i].z();
    return depth;
}

// Whether the rim refutes a pose: from min_rim_probes settled probes on, the share the scene goes
// on at is judged as measured; fewer are judged by the lower end of its 95% Wilson interval, so
// that 11 of 19 (the scene going on all around a carton posed on a jug) refutes while 1 of 5 (a
// bottle's cap and base) does not.
bool rim_refutes(std::size_t continued, std::size_t settled, const VerifyParams& verify)
{
    if (settled == 0) return false;
    const double n = double(settled), share = double(continued) / n;
    if (settled >= std::size_t(verify.min_rim_probes)) return share > verify.max_continuation;
    constexpr double z = 1.96;
    const double centre = share + z * z / (2 * n);
    const double spread = z * std::sqrt(share * (1 - share) / n + z * z / (4 * n * n));
    return (centre - spread) / (1 + z * z / n) > verify.max_continuation;
}

}  // namespace

struct ModelVerification {
    RefineParams refine;  // the parameters it was made for
    VerifyParams verify;
    std::size_t model_size = 0;          // the model's points, before thinning
    std::vector<Point> points, normals;  // the thinned model: ICP and the fit statistics need its shape, not every point
    // Self-occlusion: each thinned point stands for a disc whose radius is their mean spacing.
    float disc_radius = 0.0f;
    std::vector<Pose> quarter_turns;  // quarter and half turns about the principal axes (try_turns)
    // The confusable turns (model_turns) and the rim probes, each made when a hypothesis first needs
    // it when the preparation is refine_and_verify's own (in a scene without the object, none does).
    std::optional<std::vector<Pose>> confusable;
    std::optional<std::vector<Probe>> probes;

    ModelVerification(std::span<const Point> model_points, std::span<const Point> model_normals,
                      const RefineParams& refine_params, const VerifyParams& verify_params);
    const std::vector<Pose>& turns(std::span<const Point> model_points)
    {
        if (!confusable)
            confusable = model_turns(points, normals, model_points, verify.inlier_distance, verify.turn_overlap,
                                     refine.max_distance);
        return *confusable;
    }
    const std::vector<Probe>& rim(std::span<const Point> model_points)
    {
        if (!probes) probes = rim_probes(points, normals, model_points, verify.rim_distance);
        return *probes;
    }
};

ModelVerification::ModelVerification(std::span<const Point> model_points, std::span<const Point> model_normals,
                                     const RefineParams& refine_params, const VerifyParams& verify_params)
    : refine(refine_params), verify(verify_params), model_size(model_points.size())
{
    check_model_normals("refine_and_verify", model_points, model_normals);
    std::vector<std::uint32_t> kept;
    if (refine.model_voxel > 0.0f) kept = uniform_sampling(model_points, refine.model_voxel);
    else
        for (std::uint32_t i = 0; i < model_points.size(); ++i) kept.push_back(i);
    for (std::uint32_t i : kept) {
        points.push_back(model_points[i]);
        normals.push_back(model_normals[i]);
    }
    disc_radius = points.size() >= 2 ? float(mean_spacing(points)) : 0.0f;
    // Quarter and half turns about the model's principal axes through its centroid: the poses a
    // nearly symmetric object is mistaken for.
    if (verify.try_turns && points.size() >= 3) {
        Spread spread;
        for (const Point& p : points) spread.add(p);
        const Eigen::Vector3d centre = spread.mean();
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> axes(spread.covariance());
        for (int axis = 2; axis >= 0; --axis)
            for (const double quarter : {1.0, 2.0, 3.0}) {
                Pose turn = Pose::Identity();
                turn.linear() = Eigen::AngleAxisd(quarter * M_PI / 2.0, axes.eigenvectors().col(axis)).toRotationMatrix().cast<float>();
                turn.translation() = (centre - turn.linear().cast<double>() * centre).cast<float>();
                quarter_turns.push_back(turn);
            }
    }
}

std::shared_ptr<const ModelVerification> prepare_verification(std::span<const Point> model_points,
                                                              std::span<const Point> model_normals,
                                                              const RefineParams& refine, const VerifyParams& verify)
{
    auto prepared = std::make_shared<ModelVerification>(model_points, model_normals, refine, verify);
    if (verify.enabled) {
        prepared->rim(model_points);
        if (verify.try_turns) prepared->turns(model_points);
    }
    return prepared;
}

bool prepared_for(const ModelVerification& prepared, const RefineParams& refine, const VerifyParams& verify)
{
    return prepared.refine == refine && prepared.verify == verify;
}

SceneEvidence make_scene_evidence(const PointCloud& scene, const NeighborGrid& grid, std::optional<Camera> camera)
{
    SceneEvidence evidence;
    evidence.points = scene.points;
    evidence.grid = &grid;
    evidence.camera = camera;
    if (evidence.camera) evidence.depth = depth_image(scene);
    return evidence;
}

SceneEvidence make_scene_evidence(const PointCloud& scene, const OrganizedNeighbors& organized)
{
    if (organized.points().data() != scene.points.data() || organized.size() != scene.size())
        throw Error("make_scene_evidence", "the organized index is not over this scene");
    SceneEvidence evidence;
    evidence.points = scene.points;
    evidence.organized = &organized;
    evidence.camera = organized.camera();
    evidence.depth = depth_image(scene);
    return evidence;
}

std::vector<std::uint8_t> model_points_in_view(std::span<const Point> points, std::span<const Point> normals,
                                               const Pose& pose, float min_facing_cos, float spacing)
{
    check_model_normals("model_points_in_view", points, normals);
    std::vector<Point> placed(points.size());
    place(pose, points, placed);
    std::vector<std::uint8_t> seen(points.size()), hidden;
    SelfOcclusion work;
    seen_by_sensor(placed, normals, pose, min_facing_cos, spacing, work, hidden, seen);
    return seen;
}

std::vector<Instance> refine_and_verify(std::vector<Instance> instances, std::span<const Point> model_points,
                                        std::span<const Point> model_normals, const SceneEvidence& scene,
                                        const RefineParams& refine, const VerifyParams& verify,
                                        const ModelVerification* prepared)
{
    if (!refine.enabled && !verify.enabled) return instances;
    check_model_normals("refine_and_verify", model_points, model_normals);
    if (scene.grid == nullptr && scene.organized == nullptr) throw Error("refine_and_verify", "no scene index");
    if (prepared && (!prepared_for(*prepared, refine, verify) || prepared->model_size != model_points.size()))
        throw Error("refine_and_verify", "the model's verification was prepared for other parameters or another model");

    // Without a preparation, one of this call's own, whose turns and probes wait until a
    // hypothesis needs them. A caller's preparation is shared (by the threads of a batch): it is
    // complete, and only read.
    std::optional<ModelVerification> own;
    if (!prepared) own.emplace(model_points, model_normals, refine, verify);
    const ModelVerification& model = prepared ? *prepared : *own;
    auto turns = [&]() -> const std::vector<Pose>& { return own ? own->turns(model_points) : *prepared->confusable; };
    auto rim = [&]() -> const std::vector<Probe>& { return own ? own->rim(model_points) : *prepared->probes; };
    const std::vector<Point>& points = model.points;
    const std::vector<Point>& normals = model.normals;

    // Hypotheses in the order given (grouping's: most votes first), each against those accepted
    // before it. One that starts on the place of a settled instance (one that explains nearly all
    // of what the sensor could see of it) is taken for that object again and dropped before its
    // ICP (in clutter, most Hough maxima beside a true one are such). That trusts the order: the
    // merge below prefers the instance with more fitting points, and a later hypothesis dropped
    // here never gets to show it has more. Only
    // settled instances drop others, so that a poor fit with many votes cannot hide the true
    // objects around it: those are refined, and beat it in the merge. The points within a
    // hypothesis are what runs in parallel.
    std::vector<std::size_t> accepted;  // instance numbers; with merging, claimed[i] is accepted[i]'s place
    std::vector<std::size_t> accepted_inliers;  // per accepted: its model points that fit the scene
    std::vector<std::vector<Point>> claimed_points;
    std::vector<std::unique_ptr<NeighborGrid>> claimed;
    std::vector<std::uint8_t> settled;  // per claim
    bool any_settled = false;
    Scratch scratch(points.size());
    const float disc_radius = model.disc_radius;
    SelfOcclusion occlusion;
    const IcpView view{normals, verify.min_facing_cos, disc_radius};
    // Where two poses of one object differ (support_where_apart): on the body they share, each point
    // of one lies within about a spacing of a point of the other (a turned point of a solid of
    // revolution lands between the other's points); where they differ, farther.
    const float apart = std::max(verify.inlier_distance, 1.5f * disc_radius);
    std::vector<std::uint8_t> seen(points.size()), self_hidden;
    // The rim probes' scratch, made when a hypothesis first passes every other test.
    std::optional<Scratch> probe_scratch;
    // The model points facing the sensor at a pose, and those of them with a scene point within
    // the ICP distance: near_placed reads the model already placed at the pose in scratch.placed,
    // near_count places it there first.
    struct NearCount {
        std::size_t facing = 0, near = 0;
    };
    auto near_placed = [&](const Pose& pose) {
        NearCount count;
        for (std::size_t i = 0; i < points.size(); ++i) {
            scratch.wanted[i] = faces_camera(pose, scratch.placed[i], normals[i], verify.min_facing_cos);
            count.facing += scratch.wanted[i];
        }
        nearest_scene_points(scratch.wanted, scene, std::max(refine.max_distance, verify.inlier_distance), scratch);
        count.near = std::size_t(
            std::count_if(scratch.nearest.begin(), scratch.nearest.end(), [](std::uint32_t m) { return m != no_match; }));
        return count;
    };
    auto near_count = [&](const Pose& pose) {
        place(pose, points, scratch.placed);
        return near_placed(pose);
    };
    // ICP from an instance's pose, then every test: the number of model points fitting the scene
    // when it passes them all (scratch.placed then holds the model where the pose puts it).
    bool body_fits = false;  // whether the last pose tested passed fitness, coverage and thickness
    Pose last_pose = Pose::Identity();  // the last pose tested, with its fitting points
    std::size_t last_inliers = 0;
    // Per model point at the last pose tested: where it lies, and +1 where it fits the scene, -1
    // where the sensor would see it and saw past it, 0 otherwise (support_where_apart).
    std::vector<Point> last_placed;
    std::vector<std::int8_t> last_evidence(points.size());
    auto refine_and_test = [&](Instance& instance) -> std::optional<std::size_t> {
        body_fits = false;
        if (refine.enabled) {
            const Fit fit = icp(instance.transform, points, view, scene, refine, scratch, occlusion);
            instance.transform = fit.pose;
            instance.rmse = fit.rmse;
        }
        // Free space, for every model point whichever way its surface faces but edge on: a solid
        // object there would have stopped the sensor's ray, so a surface observed behind it
        // refutes it. A surface seen within acos(min_facing_cos) of edge on is not asked: its
        // points all project onto a strip a pixel or two wide (a box's 20 cm face, 1.4 m away and
        // turned almost along the rays, onto 3 columns), whose rays pass beside it to the table
        // at a sub-pixel error of the pose, and the sensor has no return from it to say it is
        // there. A point that faces the sensor and is not hidden (something observed in front of
        // it: no evidence for or against it) is visible: only those are looked up for fitness.
        if (refine.enabled) place(instance.transform, points, scratch.placed);  // ICP moved it
        const std::vector<Point>& at = scratch.placed;
        seen_by_sensor(at, normals, instance.transform, verify.min_facing_cos, disc_radius, occlusion, self_hidden, seen);
        std::size_t facing = 0, visible = 0, inliers = 0, projected = 0, violations = 0;
        Spread facing_spread, inlier_spread;
        for (std::size_t i = 0; i < points.size(); ++i) {
            const Point& p = at[i];
            bool hidden = false;
            last_evidence[i] = 0;
            // What the sensor could see of the object were nothing else in front of it.
            const bool faces = seen[i];
            const bool edge_on = normals[i].allFinite() &&
                                 !faces_camera(instance.transform, p, normals[i], verify.min_facing_cos) &&
                                 !faces_camera(instance.transform, p, -normals[i], verify.min_facing_cos);
            if (const std::size_t pixel = pixel_of(scene, p); pixel != no_pixel && std::isfinite(scene.depth[pixel])) {
                hidden = scene.depth[pixel] < p.z() - verify.free_space_margin;
                if (!edge_on) {
                    ++projected;
                    // Every pixel around must show a surface behind it: a point on the object's
                    // outline projects to either side of it as its pixel rounds, and the ray
                    // through the pixel beside may pass the object.
                    const bool seen_through = nearest_depth_around(scene, pixel) > p.z() + verify.free_space_margin;
                    violations += seen_through;
                    last_evidence[i] = faces && seen_through ? -1 : 0;
                }
            }
            if (faces) {
                ++facing;
                facing_spread.add(p);
            }
            scratch.wanted[i] = faces && !hidden;
            visible += scratch.wanted[i];
        }
        nearest_scene_points(scratch.wanted, scene, verify.inlier_distance, scratch);
        for (std::size_t i = 0; i < points.size(); ++i)
            if (scratch.nearest[i] != no_match) {
                ++inliers;
                inlier_spread.add(at[i]);
                last_evidence[i] = 1;
            }
        last_placed = at;
        // A side of the model that is itself flat (a box seen face on) cannot be told from a face
        // laid on a table by its shape: the test passes it.
        const float facing_thickness = facing_spread.thickness();
        instance.thickness_ratio = facing_thickness < verify.flat_side ? 1.0f : inlier_spread.thickness() / facing_thickness;
        instance.fitness = visible ? float(inliers) / float(visible) : 0.0f;
        instance.coverage = facing ? float(inliers) / float(facing) : 0.0f;
        instance.free_space_violation = projected ? float(violations) / float(projected) : 0.0f;
        body_fits = instance.fitness >= verify.min_inlier_fraction && instance.coverage >= verify.min_coverage &&
                    instance.thickness_ratio >= verify.min_thickness_ratio;
        if (instance.fitness < verify.min_inlier_fraction || instance.coverage < verify.min_coverage ||
            instance.free_space_violation > verify.max_free_space_fraction ||
            instance.thickness_ratio < verify.min_thickness_ratio)
            return std::nullopt;
        const std::vector<Probe>& probes = rim();
        if (!probe_scratch) probe_scratch.emplace(probes.size());
        const RimEvidence ends = rim_evidence(instance.transform, probes, scratch.nearest, scene, verify, *probe_scratch);
        const std::size_t rim_settled = ends.continued + ends.free;
        instance.continuation = rim_settled ? float(ends.continued) / float(rim_settled) : 0.0f;
        if (rim_refutes(ends.continued, rim_settled, verify)) return std::nullopt;
        last_pose = instance.transform;
        last_inliers = inliers;
        return inliers;
    };
    const std::vector<Pose>& quarter_turns = model.quarter_turns;
    // The depth pixels that the seen points of the pose refine_and_test just placed and tested
    // explain (explained_pixels, each point's disc a little wider than their spacing so that the
    // discs cover the surface between them); without a depth image, its fitting model points.
    std::vector<std::uint8_t> pixel_marks;
    std::vector<std::size_t> marked_pixels;
    auto explained = [&]() -> std::size_t {
        if (!scene.camera) return last_inliers;
        return explained_pixels(scene, scratch.placed, normals, last_pose, scratch.wanted, 1.5f * disc_radius,
                                verify.inlier_distance, pixel_marks, marked_pixels);
    };
    for (std::size_t n = 0; n < instances.size(); ++n) {
        Instance& instance = instances[n];
        if (verify.enabled) place(instance.transform, points, scratch.placed);  // the start, for both checks
        if (verify.enabled && verify.merge && any_settled) {
            bool same = false;
            for (std::size_t c = 0; c < claimed.size() && !same; ++c)
                same = settled[c] && overlaps(scratch.placed, *claimed[c], verify);
            if (same) continue;
        }
        // A hypothesis that explains too little of the coverage asked for, even with the looser ICP
        // distance, will not make it: reject it before paying for ICP.
        if (verify.enabled) {
            const NearCount start = near_placed(instance.transform);
            if (float(start.near) < verify.prefilter_coverage * verify.min_coverage * float(start.facing) ||
                start.facing == 0)
                continue;
        }
        if (!verify.enabled) {
            if (refine.enabled) {
                const Fit fit = icp(instance.transform, points, view, scene, refine, scratch, occlusion);
                instance.transform = fit.pose;
                instance.rmse = fit.rmse;
            }
            accepted.push_back(n);
            continue;
        }
        const std::optional<std::size_t> fitting = refine_and_test(instance);
        // A nearly symmetric object (a mug told apart by its handle, a square carton by its gable, a
        // box by its proportions) is often posed a turn away from its truth, on the body the two
        // poses share: a pose that passes every test, or that only its rim or free space refutes
        // (the handle the sensor saw left beyond its edge, or its own in front of a surface seen).
        if (!fitting && !(verify.try_turns && body_fits)) continue;
        bool passed = fitting.has_value();
        std::size_t inliers = fitting.value_or(0);
        // The pose kept, placed, and its evidence (support_where_apart).
        std::vector<Point> kept_placed = last_placed;
        std::vector<std::int8_t> kept_evidence = last_evidence;
        // A turn that starts with fewer facing points near the scene than the pose is not refined.
        auto try_turn = [&](const Pose& turn, std::size_t near) -> std::optional<Instance> {
            Instance twin;
            twin.transform = instance.transform * turn;
            if (near_count(twin.transform).near < near) return std::nullopt;
            const std::optional<std::size_t> fitting_points = refine_and_test(twin);
            if (!fitting_points) return std::nullopt;
            twin.votes = instance.votes;
            return twin;
        };
        auto adopt = [&](Instance& twin) {
            twin.correspondences = std::move(instance.correspondences);
            instance = std::move(twin);
            passed = true;
            inliers = last_inliers;
            kept_placed.swap(last_placed);
            kept_evidence.swap(last_evidence);
        };
        if (verify.try_turns) {
            // Refined and tested from each of its confusable turns (model_turns), it keeps the pose
            // the scene supports best where the two differ (support_where_apart), then, where that
            // says nothing either way (the part that tells them apart hidden at both), the pose
            // that explains the most scene pixels: the fitting model points would count a visible
            // handle against the pose that shows it.
            std::size_t explains = passed ? explained() : 0;
            const std::size_t near = near_count(instance.transform).near;
            for (const Pose& turn : turns())
                if (std::optional<Instance> twin = try_turn(turn, near)) {
                    const std::size_t more = explained();
                    const long margin = passed ? support_where_apart(last_placed, last_evidence, kept_placed, apart) -
                                                     support_where_apart(kept_placed, kept_evidence, last_placed, apart)
                                               : 1;
                    if (margin > 0 || (margin == 0 && more > explains)) {
                        adopt(*twin);
                        explains = more;
                    }
                }
            // One that passed but is not settled is also tried from quarter and half turns about the
            // model's principal axes (a box's proportions are not confusable, and a turn of them
            // shows a different side), and keeps the one with the most model points fitting the
            // scene, as the merge below judges.
            if (passed && instance.fitness < verify.settled_fitness) {
                const std::size_t quarter_near = near_count(instance.transform).near;
                for (const Pose& turn : quarter_turns)
                    if (std::optional<Instance> twin = try_turn(turn, quarter_near); twin && last_inliers > inliers)
                        adopt(*twin);
            }
            place(instance.transform, points, scratch.placed);
        }
        if (!passed) continue;
        const std::vector<Point>& at = scratch.placed;
        accepted.push_back(n);
        accepted_inliers.push_back(inliers);
        if (verify.merge) {
            claimed_points.push_back(at);
            claimed.push_back(std::make_unique<NeighborGrid>(claimed_points.back(), std::max(verify.merge_distance, 1e-3f)));
            settled.push_back(instance.fitness >= verify.settled_fitness);
            any_settled |= bool(settled.back());
        }
    }
    std::vector<std::uint8_t> keep(accepted.size(), 1);
    if (verify.enabled && verify.merge) {
        // Refined, two accepted instances may still overlap (the later started elsewhere and slid
        // onto the earlier's object): the one that explains more of the scene stays (more model
        // points fitting it, then coverage, then fitness, then the earlier). Not a share first:
        // where part of the object has no depth (cut by the frame, or no return), the true pose
        // counts those points as visible and unmatched, while a pose slid or turned off them (a
        // carton cut in half fits upside down) scores a higher fitness and coverage on fewer points.
        std::vector<std::size_t> by_strength(accepted.size());
        for (std::size_t i = 0; i < by_strength.size(); ++i) by_strength[i] = i;
        std::stable_sort(by_strength.begin(), by_strength.end(), [&](std::size_t a, std::size_t b) {
            const Instance& x = instances[accepted[a]];
            const Instance& y = instances[accepted[b]];
            if (accepted_inliers[a] != accepted_inliers[b]) return accepted_inliers[a] > accepted_inliers[b];
            return x.coverage != y.coverage ? x.coverage > y.coverage : x.fitness > y.fitness;
        });
        for (std::size_t i = 0; i < by_strength.size(); ++i)
            for (std::size_t j = 0; j < i && keep[by_strength[i]]; ++j)
                if (keep[by_strength[j]] && overlaps(claimed_points[by_strength[i]], *claimed[by_strength[j]], verify))
                    keep[by_strength[i]] = 0;
    }
    std::vector<Instance> verified;
    for (std::size_t i = 0; i < accepted.size(); ++i)
        if (keep[i]) verified.push_back(std::move(instances[accepted[i]]));
    return verified;
}

}  // namespace mfpc
