// SHOT352 with SHOT's own frame against PCL 1.13's SHOTEstimation on real clouds: same points,
// same normals (PCL's), same keypoints, radius 0.02.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include <gtest/gtest.h>
#include <pcl/console/print.h>
#include <pcl/features/shot.h>
#include <tbb/global_control.h>

#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/kernels/shot.hpp"
#include "oracle_support.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

struct Agreement {
    std::size_t keypoints = 0;
    std::size_t frames_defined = 0;     // in both
    std::size_t frames_agree = 0;       // max |element difference| < 1e-3
    std::size_t both_defined = 0;       // frame and descriptor, in both
    std::size_t descriptors_agree = 0;  // L2 difference < 1e-3
    std::size_t descriptors_close = 0;  // L2 difference < 1e-5
    std::size_t nan_mismatch = 0;       // undefined in one and not the other
    std::size_t pcl_undefined = 0;      // frame or descriptor NaN in PCL
    std::size_t pcl_frame_only = 0;     // frame defined, descriptor NaN in PCL
    double worst_descriptor = 0;
};

// Keypoints where SHOT is undefined or nearly so, appended to the regular ones so that PCL's NaN
// cases are compared too: one far from the cloud (no neighbours), some off the surface with only
// a few points within the radius, and one whose whole support has lost its normals (frame
// defined, histogram empty).
void add_edge_keypoints(test::OracleCloud& data)
{
    constexpr float nan = std::numeric_limits<float>::quiet_NaN();
    auto add = [&](const Point& p) {
        data.keypoint_points.push_back(p);
        data.pcl_keypoints->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    };
    add(data.cloud.points.front() + Point(10, 10, 10));
    // Points off the surface along the normal where 1 to 8 surface points lie within the radius,
    // around PCL's threshold of 5.
    const NeighborGrid grid(data.cloud.points, 0.02f);
    std::vector<std::uint32_t> found;
    std::vector<float> squared;
    for (std::size_t i = data.cloud.size() / 3; i < data.cloud.size(); i += data.cloud.size() / 16) {
        if (!data.normals[i].allFinite()) continue;
        for (float side : {1.0f, -1.0f}) {
            for (float lift = 0.015f; lift < 0.04f; lift += 0.0005f) {
                const Point p = data.cloud.points[i] + side * lift * data.normals[i];
                grid.radius_search(p, 0.02f, found, squared);
                if (found.size() < 9) {
                    if (!found.empty()) add(p);
                    break;
                }
            }
        }
    }
    const Point bare = data.cloud.points[data.cloud.size() / 4];
    for (std::size_t i = 0; i < data.cloud.size(); ++i) {
        if ((data.cloud.points[i] - bare).norm() < 0.025f) {
            data.normals[i] = Point::Constant(nan);
            pcl::Normal& n = (*data.pcl_normals)[i];
            n.normal_x = n.normal_y = n.normal_z = nan;
        }
    }
    add(bare);
}

Agreement compare_with_pcl(const std::filesystem::path& path, std::size_t stride, const char* name)
{
    pcl::console::setVerbosityLevel(pcl::console::L_ERROR);  // PCL warns per NaN normal
    auto data = test::load_oracle_cloud(path, stride);
    add_edge_keypoints(data);
    constexpr float radius = 0.02f;

    pcl::SHOTEstimation<pcl::PointXYZ, pcl::Normal, pcl::SHOT352> estimation;
    estimation.setRadiusSearch(0.02);  // a double, as a PCL user writes it; ours is 0.02f
    estimation.setInputCloud(data.pcl_keypoints);
    estimation.setSearchSurface(data.pcl_cloud);
    estimation.setInputNormals(data.pcl_normals);
    estimation.setSearchMethod(pcl::search::KdTree<pcl::PointXYZ>::Ptr(new pcl::search::KdTree<pcl::PointXYZ>));
    pcl::PointCloud<pcl::SHOT352> expected;
    const auto pcl_start = std::chrono::steady_clock::now();
    estimation.compute(expected);
    const double pcl_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - pcl_start).count();

    const std::size_t n = data.keypoint_points.size();
    std::vector<LocalReferenceFrame> frames(n);
    std::vector<float> descriptors(n * shot_size);
    double grid_seconds = 0, kernel_seconds = 0;
    {
        // One thread, as PCL's SHOTEstimation. The grid build is timed apart: PCL builds its two
        // kd-trees inside compute(), a pipeline builds the grid once for several kernels.
        const tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
        const auto start = std::chrono::steady_clock::now();
        const NeighborGrid grid(data.cloud.points, radius);
        const auto built = std::chrono::steady_clock::now();
        shot_descriptors(data.keypoint_points, grid, data.normals, ShotParams{radius}, frames, descriptors);
        const auto done = std::chrono::steady_clock::now();
        grid_seconds = std::chrono::duration<double>(built - start).count();
        kernel_seconds = std::chrono::duration<double>(done - built).count();
    }

    Agreement a;
    a.keypoints = n;
    for (std::size_t i = 0; i < n; ++i) {
        const pcl::SHOT352& theirs = expected[i];
        const bool pcl_frame = std::all_of(theirs.rf, theirs.rf + 9, [](float v) { return std::isfinite(v); });
        const bool pcl_descriptor =
            std::all_of(theirs.descriptor, theirs.descriptor + shot_size, [](float v) { return std::isfinite(v); });
        const float* ours = descriptors.data() + i * shot_size;
        const bool our_frame = is_valid(frames[i]);
        const bool our_descriptor = std::all_of(ours, ours + shot_size, [](float v) { return std::isfinite(v); });
        if (!pcl_frame || !pcl_descriptor) ++a.pcl_undefined;
        if (pcl_frame && !pcl_descriptor) ++a.pcl_frame_only;
        if (pcl_frame != our_frame || pcl_descriptor != our_descriptor) {
            ++a.nan_mismatch;
            continue;
        }
        if (pcl_frame) {
            ++a.frames_defined;
            float frame_difference = 0;
            for (int r = 0; r < 3; ++r) {
                for (int c = 0; c < 3; ++c)
                    frame_difference = std::max(frame_difference, std::abs(frames[i](r, c) - theirs.rf[3 * r + c]));
            }
            if (frame_difference < 1e-3f) ++a.frames_agree;
        }
        if (!pcl_descriptor) continue;
        ++a.both_defined;
        double squared = 0;
        for (std::size_t k = 0; k < shot_size; ++k) {
            const double d = double(ours[k]) - double(theirs.descriptor[k]);
            squared += d * d;
        }
        const double difference = std::sqrt(squared);
        a.worst_descriptor = std::max(a.worst_descriptor, difference);
        if (difference < 1e-3) ++a.descriptors_agree;
        if (difference < 1e-5) ++a.descriptors_close;
    }
    std::printf("[ shot/%s ] %zu keypoints, %zu undefined in PCL (%zu of them with a frame), %zu NaN mismatches; "
                "frames agree %.4f of %zu; descriptors of %zu: within 1e-3 %.4f, within 1e-5 %.4f, worst L2 %.3g\n",
                name, a.keypoints, a.pcl_undefined, a.pcl_frame_only, a.nan_mismatch,
                double(a.frames_agree) / double(std::max<std::size_t>(a.frames_defined, 1)), a.frames_defined,
                a.both_defined,
                double(a.descriptors_agree) / double(std::max<std::size_t>(a.both_defined, 1)),
                double(a.descriptors_close) / double(std::max<std::size_t>(a.both_defined, 1)), a.worst_descriptor);
    // Informational only (performance belongs to bench/): one run each, one thread.
    std::printf("[ shot/%s ] rough time, 1 thread: PCL %.3f s; mfpc kernel %.3f s + grid build %.3f s\n", name,
                pcl_seconds, kernel_seconds, grid_seconds);
    return a;
}

void expect_agreement(const Agreement& a)
{
    ASSERT_GT(a.both_defined, 0u);
    EXPECT_GT(a.pcl_undefined, a.pcl_frame_only) << "the edge keypoints should reach PCL's undefined frames";
    EXPECT_GE(a.pcl_frame_only, 1u) << "the keypoint whose support has no normals";
    EXPECT_EQ(a.nan_mismatch, 0u);
    // Measured: every frame and descriptor agrees, the worst descriptor within 2e-6 (L2).
    EXPECT_GE(double(a.frames_agree), 0.99 * double(a.frames_defined));
    EXPECT_GE(double(a.descriptors_agree), 0.99 * double(a.both_defined));
}

TEST(ShotOracle, SceneAgreesWithPcl)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_cartoon_all_small_clorox.pcd");
    expect_agreement(compare_with_pcl(path, 120, "scene"));
}

TEST(ShotOracle, ModelAgreesWithPcl)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk.pcd");
    expect_agreement(compare_with_pcl(path, 13, "milk"));
}

}  // namespace
}  // namespace mfpc
