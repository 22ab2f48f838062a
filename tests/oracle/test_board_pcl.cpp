// board_frames against PCL 1.13's BOARDLocalReferenceFrameEstimation on the real clouds, with the
// same keypoints, surface and (PCL's own) normals.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <pcl/features/board.h>
#include <pcl/search/kdtree.h>

#include "mfpc/kernels/local_reference_frame.hpp"
#include "oracle_support.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

constexpr float radius = 0.015f;

// PCL's tutorial leaves the tangent radius unset, which PCL reads as a margin ring of everything
// but the keypoint; our margin_threshold = 0 is that. Setting it to the radius gives the paper's
// ring at 0.85 r, our default.
enum class Ring { paper, pcl_default };

struct Agreement {
    std::size_t count = 0;
    std::size_t both_nan = 0;
    std::size_t nan_mismatch = 0;
    std::size_t frame_agrees = 0;  // every element within 1e-3
    std::size_t z_agrees = 0;
    std::size_t x_agrees = 0;
    std::size_t x_within_sector = 0;  // x within one hole-finding sector (15 degrees) of PCL's
    std::size_t holes = 0;          // keypoints where our x comes from a hole
    std::size_t holes_x_agrees = 0;
    double worst_z = 0.0;
    double median_difference = 0.0;  // of the largest element difference, over defined frames

    double fraction(std::size_t n) const { return double(n + both_nan) / double(count); }
};

std::vector<LocalReferenceFrame> pcl_frames(const test::OracleCloud& oracle, bool find_holes, Ring ring)
{
    pcl::BOARDLocalReferenceFrameEstimation<pcl::PointXYZ, pcl::Normal, pcl::ReferenceFrame> estimation;
    estimation.setInputCloud(oracle.pcl_keypoints);
    estimation.setSearchSurface(oracle.pcl_cloud);
    estimation.setInputNormals(oracle.pcl_normals);
    estimation.setSearchMethod(pcl::search::KdTree<pcl::PointXYZ>::Ptr(new pcl::search::KdTree<pcl::PointXYZ>));
    // The float radius widened exactly: FLANN squares it in double and rounds to float, which is
    // then the float square our grid uses.
    estimation.setRadiusSearch(double(radius));
    if (ring == Ring::paper) estimation.setTangentRadius(radius);
    estimation.setFindHoles(find_holes);
    std::srand(1);  // PCL draws its hole-finding axis with rand(): fix the draw for this run
    pcl::PointCloud<pcl::ReferenceFrame> out;
    estimation.compute(out);

    std::vector<LocalReferenceFrame> frames(out.size());
    for (std::size_t i = 0; i < out.size(); ++i) {
        for (int d = 0; d < 3; ++d) {
            frames[i](0, d) = out[i].x_axis[d];
            frames[i](1, d) = out[i].y_axis[d];
            frames[i](2, d) = out[i].z_axis[d];
        }
    }
    return frames;
}

Agreement compare(const test::OracleCloud& oracle, bool find_holes, Ring ring)
{
    const NeighborGrid grid(oracle.cloud.points, radius);
    BoardParams params;
    params.radius = radius;
    params.find_holes = find_holes;
    if (ring == Ring::pcl_default) params.margin_threshold = 0.0f;
    std::vector<LocalReferenceFrame> ours(oracle.keypoint_points.size());
    const std::size_t nan_count = board_frames(oracle.keypoint_points, grid, oracle.normals, params, ours);
    const std::vector<LocalReferenceFrame> theirs = pcl_frames(oracle, find_holes, ring);
    EXPECT_EQ(theirs.size(), ours.size());
    // Where x changes when hole finding is on, a hole set it.
    std::vector<LocalReferenceFrame> without_holes(ours.size());
    if (find_holes) {
        BoardParams no_holes = params;
        no_holes.find_holes = false;
        board_frames(oracle.keypoint_points, grid, oracle.normals, no_holes, without_holes);
    }

    Agreement a;
    a.count = ours.size();
    std::vector<float> differences;
    const float sector_cos = std::cos(2.0f * std::numbers::pi_v<float> / float(params.margin_bins));
    for (std::size_t i = 0; i < ours.size(); ++i) {
        const bool ours_valid = is_valid(ours[i]);
        const bool theirs_valid = theirs[i].allFinite();
        if (!ours_valid || !theirs_valid) {
            (ours_valid == theirs_valid ? a.both_nan : a.nan_mismatch)++;
            continue;
        }
        const float difference = (ours[i] - theirs[i]).cwiseAbs().maxCoeff();
        const float z_difference = (ours[i].row(2) - theirs[i].row(2)).cwiseAbs().maxCoeff();
        const float x_difference = (ours[i].row(0) - theirs[i].row(0)).cwiseAbs().maxCoeff();
        a.worst_z = std::max(a.worst_z, double(z_difference));
        differences.push_back(difference);
        a.frame_agrees += difference < 1e-3f;
        a.z_agrees += z_difference < 1e-3f;
        a.x_agrees += x_difference < 1e-3f;
        a.x_within_sector += ours[i].row(0).dot(theirs[i].row(0)) >= sector_cos - 1e-6f;
        if (find_holes && ours[i].row(0) != without_holes[i].row(0)) {
            ++a.holes;
            a.holes_x_agrees += x_difference < 1e-3f;
        }
    }
    if (!differences.empty()) {
        std::nth_element(differences.begin(), differences.begin() + std::ptrdiff_t(differences.size() / 2),
                         differences.end());
        a.median_difference = differences[differences.size() / 2];
    }
    EXPECT_EQ(nan_count, std::size_t(std::count_if(ours.begin(), ours.end(),
                                                   [](const LocalReferenceFrame& f) { return !is_valid(f); })));

    std::ostringstream line;
    line << (ring == Ring::paper ? "ring 0.85 r" : "ring 0") << ", find_holes " << find_holes << ": "
         << a.count << " keypoints, NaN in both " << a.both_nan << ", NaN mismatch " << a.nan_mismatch
         << "; frame within 1e-3 " << a.fraction(a.frame_agrees) * 100.0 << "%, z "
         << a.fraction(a.z_agrees) * 100.0 << "%, x " << a.fraction(a.x_agrees) * 100.0
         << "%, x within a sector " << a.fraction(a.x_within_sector) * 100.0 << "%, worst z " << a.worst_z
         << ", median difference " << a.median_difference;
    if (find_holes) line << "; holes at " << a.holes << " keypoints, x agrees at " << a.holes_x_agrees;
    std::cout << line.str() << "\n";
    ::testing::Test::RecordProperty(std::string(ring == Ring::paper ? "paper" : "pcl_default") +
                                        (find_holes ? "_holes" : "_no_holes"),
                                    line.str());
    return a;
}

// The clouds are loaded once: PCL's normals of the 240k-point scene take the longest.
const test::OracleCloud& scene(const std::filesystem::path& path)
{
    // About 2000 keypoints of the 241,407 finite scene points.
    static const test::OracleCloud cloud = test::load_oracle_cloud(path, 120);
    return cloud;
}

const test::OracleCloud& model(const std::filesystem::path& path)
{
    static const test::OracleCloud cloud = test::load_oracle_cloud(path, 7);
    return cloud;
}

// Measured (PCL rand seed 1; radius 15 mm; ~2000 keypoints each): frames within 1e-3 of PCL's
// for 99.80% (scene) and 99.80% (model) of the keypoints with the 0.85 r ring, 99.90% and 99.69%
// with ring 0; NaN exactly where PCL has NaN. Every difference is one of two kinds:
// - a near tie for the most different normal: two ring points whose cosines with z agree to ~1e-6,
//   which PCL's float SVD z (~1e-7 from ours) orders the other way; x then points elsewhere.
// - a neighbour at squared distance exactly radius^2 (Kinect depths are quantized): FLANN's
//   radius search excludes it (dist < r^2), NeighborGrid includes it (<=), so the plane fit moves
//   z by ~3e-3. Two model keypoints; this is the only reason z ever differs.
void expect_same_frames(const test::OracleCloud& oracle, Ring ring)
{
    const Agreement a = compare(oracle, false, ring);
    EXPECT_GE(a.fraction(a.frame_agrees), 0.99);
    EXPECT_EQ(a.nan_mismatch, 0u);
}

// With hole finding PCL measures angles from a random axis; ours is fixed, so the hole sectors
// are placed differently. Measured over PCL rand seeds 1 to 20: z as without holes (99.90% model,
// 100% scene); x within 1e-3 for 99.69% to 99.95% of the keypoints, the same near ties as above
// plus at most one keypoint per run where the sector placement changes the hole that is found
// (our hole keypoints: 578 and 118 on the scene, 421 and 84 on the model, for the two rings; at
// most one of them differs from PCL in any run). The thresholds leave a keypoint or two of room
// below the worst seed.
void expect_same_frames_with_holes(const test::OracleCloud& oracle, Ring ring)
{
    const Agreement a = compare(oracle, true, ring);
    EXPECT_GE(a.fraction(a.z_agrees), 0.99);
    EXPECT_GE(a.fraction(a.x_agrees), 0.995);
    EXPECT_GE(double(a.holes_x_agrees), 0.98 * double(a.holes));
    EXPECT_EQ(a.nan_mismatch, 0u);
}

TEST(BoardOracle, SceneFramesMatchPclWithoutHoles)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_cartoon_all_small_clorox.pcd");
    expect_same_frames(scene(path), Ring::paper);
    expect_same_frames(scene(path), Ring::pcl_default);
}

TEST(BoardOracle, ModelFramesMatchPclWithoutHoles)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk.pcd");
    expect_same_frames(model(path), Ring::paper);
    expect_same_frames(model(path), Ring::pcl_default);
}

TEST(BoardOracle, SceneFramesMatchPclWithHoles)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_cartoon_all_small_clorox.pcd");
    expect_same_frames_with_holes(scene(path), Ring::paper);
    expect_same_frames_with_holes(scene(path), Ring::pcl_default);
}

TEST(BoardOracle, ModelFramesMatchPclWithHoles)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk.pcd");
    expect_same_frames_with_holes(model(path), Ring::paper);
    expect_same_frames_with_holes(model(path), Ring::pcl_default);
}

}  // namespace
}  // namespace mfpc
