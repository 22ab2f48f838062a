#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "atan_fit.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/kernels/detail/lanes.hpp"
#include "mfpc/kernels/local_reference_frame.hpp"

// BOARD as PCL 1.13's BOARDLocalReferenceFrameEstimation computes it (features/impl/board.hpp),
// rewritten over our neighbour grid. Where this file departs from PCL on purpose, a comment says
// so; everything else follows PCL's arithmetic so the frames agree to float rounding.

namespace mfpc {
namespace {

constexpr float two_pi = 2.0f * std::numbers::pi_v<float>;

// A candidate neighbour ordered by (value, squared distance, index). PCL scans neighbours sorted by
// distance and keeps the first one on a strict "<", so on equal values the nearer one wins; ours
// come in grid order, and this key makes the same choice (index as the last, deterministic resort
// where FLANN's order among equal distances is unspecified).
struct Candidate {
    float value = std::numeric_limits<float>::max();
    float squared_distance = std::numeric_limits<float>::max();
    std::uint32_t index = std::numeric_limits<std::uint32_t>::max();
    bool found() const { return index != std::numeric_limits<std::uint32_t>::max(); }
};

inline bool before(float value, float squared_distance, std::uint32_t index, const Candidate& best)
{
    if (value != best.value) return value < best.value;
    if (squared_distance != best.squared_distance) return squared_distance < best.squared_distance;
    return index < best.index;
}

// One angular sector of the margin ring (PCL's check_margin_array_ and its four companions).
struct Sector {
    bool occupied = false;
    Candidate first;  // smallest angle; `value` is the angle
    Candidate last;   // largest angle; `value` is minus the angle, so that `before` picks it
    float first_cos = -1.0f;  // normal cosines of those two points
    float last_cos = -1.0f;
};

// A margin ring point, for hole finding.
struct RingPoint {
    std::uint32_t index;
    float squared_distance;
    float normal_cos;
};

// Per-task buffers, reused across the keypoints of a blocked range.
struct Scratch {
    std::vector<std::uint32_t> indices;
    std::vector<float> squared_distances;
    std::vector<std::uint32_t> tangent_indices;
    std::vector<float> tangent_squared_distances;
    std::vector<Sector> sectors;
    std::vector<RingPoint> ring;
    std::vector<float> ring_y, ring_x, ring_angles;  // the ring points' offsets along axis1, axis0
};

// The unit direction from `origin` to `point` projected on the plane normal to `axis`; zero when
// the point lies on the axis. PCL's arithmetic on purpose: it projects the point itself, (p - t
// axis) - o, which rounds at the magnitude of the coordinates (errs by ~1e-5 rad for a neighbour
// 15 mm from a keypoint 1 m away). The exact form, (p - o) - t axis, would be more accurate, but
// organized scans put neighbours exactly in line with the keypoint (one pixel row), and PCL's
// choice among such points, in the margin ring's sectors, follows these rounding errors; with the
// same arithmetic we make the same choice (on the scene, 1 hole keypoint in 10 otherwise differs).
inline Eigen::Vector3f plane_offset(const Point& axis, const Point& origin, const Point& point)
{
    const float t = axis.dot(point - origin);
    const Eigen::Vector3f projection = point - t * axis;
    return projection - origin;
}
inline Eigen::Vector3f plane_direction(const Point& axis, const Point& origin, const Point& point)
{
    Eigen::Vector3f direction = plane_offset(axis, origin, point);
    direction.normalize();  // leaves a zero vector zero, as in PCL
    return direction;
}

using detail::Float4;
using detail::Int4;

// atan2(y, x) moved into [0, 2 pi), four at a time: the polynomial on the octant's t = min / max in
// [0, 1], reflected into place. Within a few 1e-7 rad of libm's, which cost the frames a third of
// their time; and in lanes, since one at a time its latency was most of the rest. The divisor is at
// least the smallest normal float, so there is no branch (a zero offset gives 0 / that; only
// subnormal offsets, far below any real one, get a t off the ratio).
inline Float4 turn_angle(Float4 y, Float4 x)
{
    const Float4 ax = detail::abs4(x), ay = detail::abs4(y);
    const Float4 big = ax < ay ? ay : ax, small = ay < ax ? ay : ax;
    const Float4 floor = Float4{} + std::numeric_limits<float>::min();
    const Float4 t = small / (big < floor ? floor : big);
    const Float4 s = t * t;
    Float4 a = t * detail::horner(s, detail::atan_fit, 1.0);
    a = ay > ax ? 0.5f * std::numbers::pi_v<float> - a : a;
    // By the sign bit, as atan2 (the angle of (+0, -0) is pi).
    a = std::bit_cast<Int4>(x) < 0 ? std::numbers::pi_v<float> - a : a;
    return y < 0.0f ? two_pi - a : a;
}

// An axis orthogonal to `axis`, fixed. PCL draws it with std::rand(), so its frames with hole
// finding are not reproducible (and rand() is shared state, racy across threads). The axis only
// places the sector boundaries: angles are measured from it and x is rotated back about the same
// axis, and a hole's width and position come from the two ring points that bound the gap. So a
// gap that empties a whole sector gives the same x whatever the axis, and any gap wider than two
// sectors does. The placement decides only narrower gaps (which never pass the default
// hole_size_probability of 0.2 with 24 sectors) and one quirk kept from PCL: ring points all
// within one sector make a negative width and no hole, while the same points split across two
// sectors make a hole of almost the full turn. There our x can differ from a given PCL draw: at
// most one keypoint in ~2000 per draw on the real clouds. The axis: the coordinate axis least
// aligned with `axis`, made orthogonal to it.
inline Eigen::Vector3f orthogonal_axis(const Point& axis)
{
    Eigen::Index least = 0;
    axis.cwiseAbs().minCoeff(&least);
    Eigen::Vector3f result = Eigen::Vector3f::Unit(least);
    result -= axis.dot(result) * axis;
    return result.normalized();
}

inline void set_undefined(LocalReferenceFrame& frame)
{
    frame.setConstant(std::numeric_limits<float>::quiet_NaN());
}

inline void set_frame(LocalReferenceFrame& frame, const Eigen::Vector3f& x, const Eigen::Vector3f& z)
{
    frame.row(0) = x.transpose();
    frame.row(1) = z.cross(x).transpose();
    frame.row(2) = z.transpose();
}

// The frame at one keypoint. Returns nothing: an undefined frame is written as NaN.
// `support`: when given, the neighbourhoods of the keypoints (this one is `at`) to take the
// supports from instead of searching the grid.
void board_frame(const Point& keypoint, const NeighborGrid& surface, std::span<const Point> normals,
                 const BoardParams& params, const Neighborhoods* support, std::size_t at, Scratch& scratch,
                 LocalReferenceFrame& frame)
{
    // A NaN keypoint has no neighbourhood (and PCL asserts on it).
    if (!keypoint.allFinite()) return set_undefined(frame);
    const auto points = surface.points();
    struct Found {
        std::span<const std::uint32_t> indices;
        std::span<const float> squared_distances;
    };
    auto neighbours = [&](float radius, std::vector<std::uint32_t>& indices,
                          std::vector<float>& squared_distances) -> Found {
        // The support's own lists when they are exactly these: read in place, not copied.
        if (support && radius == support->radius) return {support->indices_of(at), support->squared_distances_of(at)};
        if (support) {
            support->within(at, radius, indices, squared_distances);
        } else {
            surface.radius_search(keypoint, radius, indices, squared_distances);
        }
        return {indices, squared_distances};
    };

    // z axis: the normal of the least-squares plane through the neighbours.
    const Found plane = neighbours(params.radius, scratch.indices, scratch.squared_distances);
    if (plane.indices.size() < 6) return set_undefined(frame);
    // PCL takes the last right singular vector of the centred float points (JacobiSVD). That is
    // the smallest eigenvector of their scatter matrix, which we form in double with a two-pass
    // mean: the same axis, to float rounding, independent of the neighbour order and without
    // PCL's per-keypoint heap matrices.
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const std::uint32_t n : plane.indices) mean += points[n].cast<double>();
    mean /= double(plane.indices.size());
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (const std::uint32_t n : plane.indices) {
        const Eigen::Vector3d d = points[n].cast<double>() - mean;
        scatter.noalias() += d * d.transpose();
    }
    // All neighbours at one spot: no plane. PCL returns a frame with zero x and y rows here.
    if (!(scatter.trace() > 0.0)) return set_undefined(frame);
    // compute(), not computeDirect(): the closed form loses the smallest eigenvector's accuracy
    // on nearly flat patches, which are the common case.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
    Eigen::Vector3f z = solver.eigenvectors().col(0).cast<float>();

    // Sign of z: towards the mean of the neighbours' normals. PCL sums every normal, so one NaN
    // normal makes the mean NaN and leaves the sign to the SVD; we skip undefined normals.
    Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
    for (const std::uint32_t n : plane.indices) {
        if (normals[n].allFinite()) normal_sum += normals[n].cast<double>();
    }
    if (z.cast<double>().dot(normal_sum) < 0.0) z = -z;

    // x axis: towards the neighbour (in the tangent support) whose normal is the most different
    // from z, taken from the margin ring when it has any point.
    const bool own_tangent_support = params.tangent_radius != 0.0f && params.tangent_radius != params.radius;
    const float tangent_radius = own_tangent_support ? params.tangent_radius : params.radius;
    const Found tangent =
        own_tangent_support ? neighbours(tangent_radius, scratch.tangent_indices, scratch.tangent_squared_distances)
                            : plane;
    const auto indices = tangent.indices;
    const auto squared_distances = tangent.squared_distances;
    // The float expression and the strict ">" of PCL, so points on the ring boundary fall alike.
    const float margin2 = params.margin_threshold * params.margin_threshold * (tangent_radius * tangent_radius);

    const int sector_count = params.margin_bins;
    const float sectors_per_radian = float(sector_count) / two_pi;
    Eigen::Vector3f axis0 = Eigen::Vector3f::Zero();
    Eigen::Vector3f axis1 = Eigen::Vector3f::Zero();
    if (params.find_holes) {
        axis0 = orthogonal_axis(z);
        axis1 = z.cross(axis0);
        scratch.sectors.assign(std::size_t(sector_count), Sector{});
    }

    // One pass keeps the best point of the ring and of the inside: PCL's second pass over the
    // inside, run only when the ring is empty, picks the same point. It also gathers the ring for
    // hole finding, whose angles come next in a loop of their own: one at a time, the polynomial's
    // latency (and the mispredicted compares around it) were most of the frames' time.
    Candidate best_margin;
    Candidate best_inner;
    scratch.ring.clear();
    scratch.ring_y.clear();
    scratch.ring_x.clear();
    for (std::size_t j = 0; j < indices.size(); ++j) {
        const std::uint32_t n = indices[j];
        const float d2 = squared_distances[j];
        // An undefined normal takes no part in choosing x. In PCL its NaN cosine never wins but
        // still counts as a ring point and can poison a hole's steepness test; here it is absent.
        if (!normals[n].allFinite()) continue;
        const float normal_cos = z.dot(normals[n]);
        if (d2 <= margin2) {
            if (before(normal_cos, d2, n, best_inner)) best_inner = {normal_cos, d2, n};
            continue;
        }
        if (before(normal_cos, d2, n, best_margin)) best_margin = {normal_cos, d2, n};
        if (!params.find_holes) continue;
        const Eigen::Vector3f direction = plane_offset(z, keypoint, points[n]);
        scratch.ring.push_back({n, d2, normal_cos});
        scratch.ring_y.push_back(direction.dot(axis1));
        scratch.ring_x.push_back(direction.dot(axis0));
    }
    // PCL: acos of the cosine with axis0, mirrored to 2 pi - angle when the sine is negative.
    // atan2 gives the same angle in [0, 2 pi) without acos's loss near 0 and pi (up to 3e-4 rad in
    // float). It needs no unit direction, so the offset is not normalized.
    const std::size_t ring_size = scratch.ring.size();
    const std::size_t padded = (ring_size + detail::lanes - 1) / detail::lanes * detail::lanes;
    scratch.ring_y.resize(padded, 0.0f);
    scratch.ring_x.resize(padded, 0.0f);
    scratch.ring_angles.resize(padded);
    for (std::size_t r = 0; r < padded; r += detail::lanes)
        detail::store(scratch.ring_angles.data() + r,
                      turn_angle(detail::load(scratch.ring_y.data() + r), detail::load(scratch.ring_x.data() + r)));
    for (std::size_t r = 0; r < ring_size; ++r) {
        const auto [n, d2, normal_cos] = scratch.ring[r];
        const float angle = scratch.ring_angles[r];
        const int s = std::min(int(angle * sectors_per_radian), sector_count - 1);
        Sector& sector = scratch.sectors[std::size_t(s)];
        sector.occupied = true;
        if (before(angle, d2, n, sector.first)) {
            sector.first = {angle, d2, n};
            sector.first_cos = normal_cos;
        }
        if (before(-angle, d2, n, sector.last)) {
            sector.last = {-angle, d2, n};
            sector.last_cos = normal_cos;
        }
    }

    const auto towards = [&](std::uint32_t n) {
        const Eigen::Vector3f direction = plane_direction(z, keypoint, points[n]);
        // A neighbour straight above or below the keypoint gives no direction (PCL: zero x, y).
        if (!(direction.squaredNorm() > 0.0f)) return set_undefined(frame);
        // PCL's rounding leaves x off the plane by up to ~1e-5 (more far from the origin); one
        // more projection makes the frame orthonormal to float precision and moves x by no more.
        set_frame(frame, (direction - z.dot(direction) * z).normalized(), z);
    };

    // Empty ring: x from the inside, no hole finding (as PCL). No defined normal at all: undefined.
    if (!best_margin.found()) {
        if (!best_inner.found()) return set_undefined(frame);
        return towards(best_inner.index);
    }
    if (!params.find_holes) return towards(best_margin.index);

    const auto& sectors = scratch.sectors;
    if (std::all_of(sectors.begin(), sectors.end(), [](const Sector& s) { return s.occupied; }))
        return towards(best_margin.index);

    // Holes: runs of empty sectors. A hole wide enough (hole_size_probability of the full turn,
    // measured between the points that bound it) with steep enough borders (their normals far
    // from z, relative to the most different normal) sets x inside it, nearer the steeper border.
    // The widest such hole wins, the first one scanned on a tie. This follows PCL step for step,
    // including its quirks: the scan starts after a run that wraps past the last sector, and with
    // a single occupied sector the width comes out negative, so that hole never qualifies.
    const float min_cos = best_margin.value;
    float best_probability = -std::numeric_limits<float>::max();
    float hole_angle = 0.0f;
    int start = 0;
    if (!sectors.back().occupied) {
        start = int(std::find_if(sectors.begin(), sectors.end(), [](const Sector& s) { return s.occupied; }) -
                    sectors.begin());
    }
    for (int s = start; s < sector_count; ++s) {
        if (sectors[std::size_t(s)].occupied) continue;
        const int hole_first = s;
        int hole_end = hole_first + 1;
        while (!sectors[std::size_t(hole_end % sector_count)].occupied) ++hole_end;
        const int previous = (hole_first - 1 + sector_count) % sector_count;
        const int following = hole_end % sector_count;
        const Sector& before_hole = sectors[std::size_t(previous)];
        const Sector& after_hole = sectors[std::size_t(following)];
        const float begin_angle = -before_hole.last.value;
        const float end_angle = after_hole.first.value;
        // Steepness of each border in [0, 1]: 1 for the most different normal, 0 for one along z.
        const float normal_begin = 1.0f - (before_hole.last_cos - min_cos) / (1.0f - min_cos);
        const float normal_end = 1.0f - (after_hole.first_cos - min_cos) / (1.0f - min_cos);
        const float width = following < previous ? end_angle + two_pi - begin_angle : end_angle - begin_angle;
        const float probability = width / two_pi;
        const float steepness = (normal_end + normal_begin) / 2.0f;
        if (probability > params.hole_size_probability && steepness > params.steep_threshold &&
            probability > best_probability) {
            best_probability = probability;
            const float weight = ((normal_end - normal_begin) + 1.0f) / 2.0f;
            hole_angle = begin_angle + width * weight;
        }
        if (hole_end >= sector_count) break;
        s = hole_end - 1;
    }
    if (!(best_probability > -std::numeric_limits<float>::max())) return towards(best_margin.index);
    // axis0 rotated by hole_angle about z.
    const Eigen::Vector3f x = std::cos(hole_angle) * axis0 + std::sin(hole_angle) * axis1;
    set_frame(frame, x, z);
}

}  // namespace

std::size_t board_frames(std::span<const Point> keypoints, const NeighborGrid& surface,
                         std::span<const Point> surface_normals, const BoardParams& params,
                         std::span<LocalReferenceFrame> frames, const Neighborhoods* support)
{
    const char* const where = "board_frames";
    if (surface_normals.size() != surface.size())
        throw Error(where, "surface_normals has " + std::to_string(surface_normals.size()) + " entries for " +
                               std::to_string(surface.size()) + " surface points");
    if (frames.size() != keypoints.size())
        throw Error(where, "frames has " + std::to_string(frames.size()) + " entries for " +
                               std::to_string(keypoints.size()) + " keypoints");
    if (!(params.radius > 0.0f) || !std::isfinite(params.radius))
        throw Error(where, "radius must be a positive number, got " + format_number(params.radius));
    if (!(params.tangent_radius >= 0.0f) || !std::isfinite(params.tangent_radius))
        throw Error(where, "tangent_radius must be 0 (the radius) or a positive number, got " +
                               format_number(params.tangent_radius));
    if (params.margin_bins < 1)
        throw Error(where, "margin_bins must be at least 1, got " + std::to_string(params.margin_bins));
    if (!(params.margin_threshold >= 0.0f) || !std::isfinite(params.margin_threshold))
        throw Error(where, "margin_threshold must be a number >= 0, got " + format_number(params.margin_threshold));
    if (!std::isfinite(params.hole_size_probability) || !std::isfinite(params.steep_threshold))
        throw Error(where, "hole_size_probability and steep_threshold must be numbers");
    if (support)
        support->check_serves(surface.points(), keypoints, std::max(params.radius, params.tangent_radius), where,
                              "the frames");

    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, keypoints.size(), 64), [&](const auto& range) {
        Scratch scratch;
        for (std::size_t i = range.begin(); i < range.end(); ++i)
            board_frame(keypoints[i], surface, surface_normals, params, support, i, scratch, frames[i]);
    });
    return std::size_t(std::count_if(frames.begin(), frames.end(),
                                     [](const LocalReferenceFrame& f) { return !is_valid(f); }));
}

}  // namespace mfpc
