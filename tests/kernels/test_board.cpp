// Properties of board_frames that hold whatever PCL does: orthonormal right-handed frames, the
// plane normal as z on a plane, undefined frames where the support is too small, the same bits at
// any thread count, and errors on bad input. Agreement with PCL is in tests/oracle.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <tbb/global_control.h>

#include "mfpc/core/error.hpp"
#include "mfpc/kernels/local_reference_frame.hpp"

namespace mfpc {
namespace {

// A curved, noisy surface patch: z = 0.5 (a x^2 + b y^2) plus a bump, so that normals vary around
// the keypoints, with a random tilt and offset, sampled on a jittered 1.5 mm grid over 8 cm, with
// the exact surface normals (before the noise). Keypoints near its edge see holes.
struct Surface {
    std::vector<Point> points;
    std::vector<Point> normals;
};

Surface curved_patch(std::uint32_t seed, float noise)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    std::normal_distribution<float> gauss(0.0f, 1.0f);
    const float a = 20.0f * uniform(rng);
    const float b = 20.0f * uniform(rng);
    const Eigen::Matrix3f tilt =
        Eigen::AngleAxisf(0.5f * uniform(rng), Eigen::Vector3f(uniform(rng), uniform(rng), 1.0f).normalized())
            .toRotationMatrix();
    // 1 to 4 m from the origin, the range of a depth camera, where float coordinates are coarsest.
    const Point offset(0.3f * uniform(rng), 0.3f * uniform(rng), 1.0f + float(seed % 4));
    Surface s;
    const float step = 0.0015f;
    for (float x = -0.04f; x <= 0.04f; x += step) {
        for (float y = -0.04f; y <= 0.04f; y += step) {
            const float px = x + 0.3f * step * uniform(rng);
            const float py = y + 0.3f * step * uniform(rng);
            const float bump = 0.01f * std::exp(-(px * px + py * py) / (2.0f * 0.01f * 0.01f));
            const float pz = 0.5f * (a * px * px + b * py * py) + bump + noise * gauss(rng);
            // Gradient of the height field.
            const float gx = a * px - bump * px / (0.01f * 0.01f);
            const float gy = b * py - bump * py / (0.01f * 0.01f);
            s.points.push_back(tilt * Point(px, py, pz) + offset);
            s.normals.push_back(tilt * Point(-gx, -gy, 1.0f).normalized());
        }
    }
    return s;
}

std::vector<Point> every(const std::vector<Point>& points, std::size_t stride)
{
    std::vector<Point> out;
    for (std::size_t i = 0; i < points.size(); i += stride) out.push_back(points[i]);
    return out;
}

std::size_t run(const Surface& surface, std::span<const Point> keypoints, const BoardParams& params,
                std::vector<LocalReferenceFrame>& frames)
{
    const NeighborGrid grid(surface.points, params.radius);
    frames.assign(keypoints.size(), LocalReferenceFrame::Zero());
    return board_frames(keypoints, grid, surface.normals, params, frames);
}

TEST(Board, FramesAreOrthonormalAndRightHanded)
{
    for (std::uint32_t seed = 1; seed <= 4; ++seed) {
        const Surface surface = curved_patch(seed, 0.0005f);
        const auto keypoints = every(surface.points, 7);
        for (const bool find_holes : {false, true}) {
            for (const float margin : {0.85f, 0.0f}) {
                BoardParams params;
                params.find_holes = find_holes;
                params.margin_threshold = margin;
                std::vector<LocalReferenceFrame> frames;
                const std::size_t nan_count = run(surface, keypoints, params, frames);
                std::size_t checked = 0;
                for (const auto& frame : frames) {
                    if (!is_valid(frame)) continue;
                    ++checked;
                    // Measured: within 5e-7 (float rounding of one projection and normalization).
                    const Eigen::Matrix3f gram = frame * frame.transpose();
                    ASSERT_LT((gram - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff(), 1e-5f) << "seed " << seed;
                    const Eigen::Vector3f x = frame.row(0), y = frame.row(1), z = frame.row(2);
                    ASSERT_LT((x.cross(y) - z).cwiseAbs().maxCoeff(), 1e-5f) << "seed " << seed;
                }
                EXPECT_EQ(checked + nan_count, frames.size());
                // Only the patch's corners can be too sparse: most frames are defined.
                EXPECT_GT(checked, frames.size() * 9 / 10);
            }
        }
    }
}

TEST(Board, ZIsThePlaneNormalOnANoisyPlane)
{
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    std::normal_distribution<float> gauss(0.0f, 0.0002f);
    std::normal_distribution<float> unit(0.0f, 1.0f);
    const Point normal = Point(0.3f, -0.2f, 1.0f).normalized();
    const Point u = normal.unitOrthogonal();
    const Point v = normal.cross(u);
    const Point origin(0.1f, 0.2f, 0.9f);
    Surface plane;
    for (int i = 0; i < 4000; ++i) {
        plane.points.push_back(origin + 0.05f * uniform(rng) * u + 0.05f * uniform(rng) * v + gauss(rng) * normal);
        // Normals estimated on noisy data scatter around the true one; half of them point away, as
        // unoriented normals would, but the mean is still on the +normal side.
        Point n = (normal + 0.05f * Point(unit(rng), unit(rng), unit(rng))).normalized();
        if (i % 3 == 0) n = -n;
        plane.normals.push_back(n);
    }
    std::vector<Point> keypoints;
    for (int i = 0; i < 200; ++i) keypoints.push_back(origin + 0.03f * uniform(rng) * u + 0.03f * uniform(rng) * v);
    for (const bool find_holes : {false, true}) {
        BoardParams params;
        params.find_holes = find_holes;
        std::vector<LocalReferenceFrame> frames;
        EXPECT_EQ(run(plane, keypoints, params, frames), 0u);
        for (const auto& frame : frames) {
            // The noise (0.2 mm over a 15 mm support of ~280 points) tilts the fit by about 1e-3.
            const Eigen::Vector3f z = frame.row(2);
            // The noise tilts the fit by about 0.2 mm / (sqrt(280) * 7.5 mm) = 1.6e-3 rad per axis
            // (~280 points in the 15 mm support); measured worst of the 200: 5.2e-3 rad.
            EXPECT_LT(std::acos(std::min(1.0f, z.dot(normal))), 0.01f);
        }
    }
}

TEST(Board, FewerThanSixNeighboursGiveNanAndAreCounted)
{
    Surface surface;
    // A cluster of exactly 5 points, and one of 6, 1 m apart.
    for (int i = 0; i < 5; ++i) {
        surface.points.push_back(Point(0.001f * float(i), 0.0005f * float(i * i), 0.0f));
        surface.normals.push_back(Point::UnitZ());
    }
    for (int i = 0; i < 6; ++i) {
        surface.points.push_back(Point(1.0f + 0.002f * float(i % 3), 0.002f * float(i / 3), 0.0001f * float(i)));
        // Distinct normals: x then points at the one most different from z, not at the keypoint.
        surface.normals.push_back(Point(0.05f * float(i), 0.02f * float(i), 1.0f).normalized());
    }
    const std::vector<Point> keypoints{surface.points[0], surface.points[5], Point(5.0f, 5.0f, 5.0f),
                                       Point::Constant(std::numeric_limits<float>::quiet_NaN())};
    std::vector<LocalReferenceFrame> frames;
    EXPECT_EQ(run(surface, keypoints, BoardParams{}, frames), 3u);
    EXPECT_TRUE(frames[0].array().isNaN().all());
    EXPECT_TRUE(is_valid(frames[1]));
    EXPECT_TRUE(frames[2].array().isNaN().all());
    EXPECT_TRUE(frames[3].array().isNaN().all());

    // Six neighbours whose normals are all undefined: no x axis, so no frame.
    Surface undefined = surface;
    for (auto& n : undefined.normals) n = Point::Constant(std::numeric_limits<float>::quiet_NaN());
    EXPECT_EQ(run(undefined, std::vector<Point>{surface.points[5]}, BoardParams{}, frames), 1u);
    EXPECT_TRUE(frames[0].array().isNaN().all());
}

TEST(Board, SameBitsAtAnyThreadCount)
{
    const Surface surface = curved_patch(11, 0.001f);
    // A few undefined normals, so that path runs too.
    Surface holed = surface;
    for (std::size_t i = 0; i < holed.normals.size(); i += 37)
        holed.normals[i] = Point::Constant(std::numeric_limits<float>::quiet_NaN());
    const auto keypoints = every(holed.points, 3);
    for (const bool find_holes : {false, true}) {
        BoardParams params;
        params.find_holes = find_holes;
        params.margin_threshold = find_holes ? 0.0f : 0.85f;
        std::vector<LocalReferenceFrame> one, two;
        std::size_t nan_one = 0, nan_two = 0;
        {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
            nan_one = run(holed, keypoints, params, one);
        }
        {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
            nan_two = run(holed, keypoints, params, two);
        }
        EXPECT_EQ(nan_one, nan_two);
        ASSERT_EQ(one.size(), two.size());
        EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size() * sizeof(LocalReferenceFrame)), 0);
    }
}

// Frames from neighbourhoods shared at a larger radius (as SHOT's) are the frames of the kernel's
// own searches, bit for bit, with and without a tangent radius of their own.
TEST(Board, SharedNeighborhoodsGiveTheSameFrames)
{
    const Surface surface = curved_patch(2, 0.0005f);
    const auto keypoints = every(surface.points, 11);
    const NeighborGrid grid(surface.points, 0.02f);
    const Neighborhoods shared = grid.radius_neighborhoods(keypoints, 0.02f);
    for (const float tangent : {0.0f, 0.012f, 0.02f}) {
        BoardParams params;
        params.tangent_radius = tangent;
        std::vector<LocalReferenceFrame> searched(keypoints.size()), read(keypoints.size());
        const std::size_t undefined = board_frames(keypoints, grid, surface.normals, params, searched);
        EXPECT_EQ(board_frames(keypoints, grid, surface.normals, params, read, &shared), undefined);
        EXPECT_EQ(std::memcmp(searched.data(), read.data(), searched.size() * sizeof(LocalReferenceFrame)), 0)
            << "tangent radius " << tangent;
    }
    // Neighbourhoods too small for a support, of other keypoints or of another surface are refused.
    std::vector<LocalReferenceFrame> frames(keypoints.size());
    const Neighborhoods small = grid.radius_neighborhoods(keypoints, 0.01f);
    EXPECT_THROW(board_frames(keypoints, grid, surface.normals, BoardParams{}, frames, &small), Error);
    BoardParams wide;
    wide.tangent_radius = 0.03f;
    EXPECT_THROW(board_frames(keypoints, grid, surface.normals, wide, frames, &shared), Error);
    const Neighborhoods fewer = grid.radius_neighborhoods(std::span(keypoints).first(3), 0.02f);
    EXPECT_THROW(board_frames(keypoints, grid, surface.normals, BoardParams{}, frames, &fewer), Error);
    std::vector<Point> moved = keypoints;
    moved[0].x() += 0.001f;
    const Neighborhoods elsewhere = grid.radius_neighborhoods(moved, 0.02f);
    EXPECT_THROW(board_frames(keypoints, grid, surface.normals, BoardParams{}, frames, &elsewhere), Error);
    const std::vector<Point> copy = surface.points;
    const NeighborGrid other(copy, 0.02f);
    const Neighborhoods other_surface = other.radius_neighborhoods(keypoints, 0.02f);
    EXPECT_THROW(board_frames(keypoints, grid, surface.normals, BoardParams{}, frames, &other_surface), Error);
}

TEST(Board, BadInputThrows)
{
    const Surface surface = curved_patch(3, 0.0f);
    const NeighborGrid grid(surface.points, 0.015f);
    const auto keypoints = every(surface.points, 100);
    std::vector<LocalReferenceFrame> frames(keypoints.size());
    const std::vector<Point> short_normals(surface.normals.begin(), surface.normals.end() - 1);
    EXPECT_THROW(board_frames(keypoints, grid, short_normals, BoardParams{}, frames), Error);
    std::vector<LocalReferenceFrame> short_frames(keypoints.size() - 1);
    EXPECT_THROW(board_frames(keypoints, grid, surface.normals, BoardParams{}, short_frames), Error);
    for (const float radius : {0.0f, -0.01f, std::numeric_limits<float>::quiet_NaN(),
                               std::numeric_limits<float>::infinity()}) {
        BoardParams params;
        params.radius = radius;
        EXPECT_THROW(board_frames(keypoints, grid, surface.normals, params, frames), Error) << radius;
    }
    BoardParams params;
    params.margin_bins = 0;
    EXPECT_THROW(board_frames(keypoints, grid, surface.normals, params, frames), Error);
    params = BoardParams{};
    params.tangent_radius = -1.0f;
    EXPECT_THROW(board_frames(keypoints, grid, surface.normals, params, frames), Error);
    params = BoardParams{};
    params.margin_threshold = std::numeric_limits<float>::quiet_NaN();
    EXPECT_THROW(board_frames(keypoints, grid, surface.normals, params, frames), Error);
    try {
        board_frames(keypoints, grid, short_normals, BoardParams{}, frames);
    } catch (const Error& e) {
        EXPECT_EQ(e.where(), "board_frames");
    }
}

}  // namespace
}  // namespace mfpc
