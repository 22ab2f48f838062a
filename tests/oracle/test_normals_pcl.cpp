#include <cmath>
#include <iostream>

#include <gtest/gtest.h>

#include "mfpc/kernels/normals.hpp"
#include "oracle_support.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

// Fraction of points whose normal is within `tolerance` radians of PCL's (same orientation), and
// NaN agreement, for k = 10 on a whole real cloud.
void expect_normals_agree(const std::filesystem::path& path)
{
    const auto oracle = test::load_oracle_cloud(path, 1);
    const NeighborGrid grid(oracle.cloud.points, 0.004f);
    std::vector<Point> normals(oracle.cloud.size());
    estimate_normals(oracle.cloud.points, grid, NormalParams{}, normals);

    std::size_t close = 0, both_nan = 0, nan_mismatch = 0;
    double worst = 0.0;
    for (std::size_t i = 0; i < normals.size(); ++i) {
        const Point& ours = normals[i];
        const Point& theirs = oracle.normals[i];
        if (!ours.allFinite() || !theirs.allFinite()) {
            (ours.allFinite() == theirs.allFinite() ? both_nan : nan_mismatch)++;
            continue;
        }
        const double cosine = std::clamp(double(ours.normalized().dot(theirs.normalized())), -1.0, 1.0);
        const double angle = std::acos(cosine);
        worst = std::max(worst, angle);
        if (angle < 1e-3) ++close;
    }
    const double fraction = double(close + both_nan) / double(normals.size());
    std::cout << path.filename().string() << ": " << normals.size() << " normals, " << fraction * 100.0
              << "% within 1e-3 rad of PCL, NaN in both " << both_nan << ", NaN mismatch " << nan_mismatch
              << ", worst " << worst << " rad\n";
    EXPECT_GE(fraction, 0.99);
    EXPECT_EQ(nan_mismatch, 0u);
}

TEST(NormalsOracle, SceneAgreesWithPclNormalEstimation)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_cartoon_all_small_clorox.pcd");
    expect_normals_agree(path);
}

TEST(NormalsOracle, ModelAgreesWithPclNormalEstimation)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk.pcd");
    expect_normals_agree(path);
}

}  // namespace
}  // namespace mfpc
