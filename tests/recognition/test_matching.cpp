#include <algorithm>
#include <cmath>
#include <random>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/kernels/shot.hpp"
#include "mfpc/recognition/matching.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

// Features with only what matching reads: unit-norm 352-D descriptors (SHOT's are).
Features random_features(std::size_t count, std::mt19937& rng)
{
    std::normal_distribution<float> normal;
    Features f;
    f.keypoints.assign(count, Point::Zero());
    f.descriptors.resize(count * shot_size);
    for (std::size_t i = 0; i < count; ++i) {
        float* d = f.descriptors.data() + i * shot_size;
        double norm = 0.0;
        for (std::size_t j = 0; j < shot_size; ++j) {
            d[j] = std::abs(normal(rng));
            norm += double(d[j]) * d[j];
        }
        for (std::size_t j = 0; j < shot_size; ++j) d[j] = float(d[j] / std::sqrt(norm));
    }
    return f;
}

// `from`'s descriptor i, a little perturbed, as `to`'s descriptor j: a near match.
void plant_near_copy(const Features& from, std::size_t i, Features& to, std::size_t j, float noise, std::mt19937& rng)
{
    std::normal_distribution<float> normal(0.0f, noise);
    for (std::size_t d = 0; d < shot_size; ++d)
        to.descriptors[j * shot_size + d] = std::max(0.0f, from.descriptors[i * shot_size + d] + normal(rng));
}

// Every pair below the threshold, in double, the k best of each query by (distance, index): the
// definition the searches must meet.
std::vector<Correspondence> brute_force(const Features& model, const Features& scene, const MatchParams& params)
{
    const bool model_to_scene = params.direction == MatchDirection::model_to_scene;
    const Features& queried = model_to_scene ? model : scene;
    const Features& indexed = model_to_scene ? scene : model;
    const std::size_t k = model_to_scene ? std::size_t(params.k) : 1;
    std::vector<Correspondence> out;
    for (std::size_t q = 0; q < queried.size(); ++q) {
        std::vector<std::pair<double, std::uint32_t>> near;
        for (std::size_t j = 0; j < indexed.size(); ++j) {
            double d2 = 0.0;
            for (std::size_t d = 0; d < shot_size; ++d) {
                const double diff = double(queried.descriptors[q * shot_size + d]) - indexed.descriptors[j * shot_size + d];
                d2 += diff * diff;
            }
            near.emplace_back(d2, std::uint32_t(j));
        }
        std::sort(near.begin(), near.end());
        for (std::size_t n = 0; n < std::min(k, near.size()) && near[n].first < params.threshold; ++n)
            out.push_back(model_to_scene ? Correspondence{std::uint32_t(q), near[n].second, float(near[n].first)}
                                         : Correspondence{near[n].second, std::uint32_t(q), float(near[n].first)});
    }
    std::sort(out.begin(), out.end(), [](const Correspondence& a, const Correspondence& b) {
        return std::tie(a.model, a.scene) < std::tie(b.model, b.scene);
    });
    return out;
}

void expect_same_pairs(const std::vector<Correspondence>& found, const std::vector<Correspondence>& expected,
                       const char* what)
{
    ASSERT_EQ(found.size(), expected.size()) << what;
    for (std::size_t i = 0; i < found.size(); ++i) {
        EXPECT_EQ(found[i].model, expected[i].model) << what << " pair " << i;
        EXPECT_EQ(found[i].scene, expected[i].scene) << what << " pair " << i;
        EXPECT_NEAR(found[i].distance, expected[i].distance, 1e-5f) << what << " pair " << i;
    }
}

// Random descriptors with planted near matches (several per model descriptor, so that k matters),
// exact duplicates (ties, which the lower index wins) and sizes that are not multiples of the
// scan's tiles and blocks: the scan and the kd-tree both find exactly the brute-force pairs.
TEST(Matching, ExactSearchesFindTheBruteForcePairs)
{
    std::mt19937 rng(7);
    const Features model = random_features(101, rng);
    Features scene = random_features(233, rng);
    for (std::size_t i = 0; i < 60; ++i)
        for (std::size_t copy = 0; copy < 3; ++copy)
            plant_near_copy(model, i, scene, (i * 3 + copy * 71) % scene.size(), 0.004f * float(copy + 1), rng);
    // Model descriptor 100 copied exactly to scene 200, 201 and 232: a three-way tie at distance 0.
    plant_near_copy(model, 100, scene, 200, 0.0f, rng);
    std::copy_n(scene.descriptors.begin() + 200 * shot_size, shot_size, scene.descriptors.begin() + 201 * shot_size);
    std::copy_n(scene.descriptors.begin() + 200 * shot_size, shot_size, scene.descriptors.begin() + 232 * shot_size);

    for (const MatchDirection direction : {MatchDirection::model_to_scene, MatchDirection::scene_to_model}) {
        for (const int k : {1, 2, 10}) {
            MatchParams params;
            params.direction = direction;
            params.k = k;
            params.threshold = 0.05f;
            const auto expected = brute_force(model, scene, params);
            ASSERT_GT(expected.size(), 60u);
            params.search = MatchSearch::scan;
            const auto scanned = match_descriptors(model, scene, params);
            expect_same_pairs(scanned, expected, "scan");
            if (direction == MatchDirection::model_to_scene && k == 1) {
                // The tie: model 100 is equally near scene 200, 201 and 232; the lowest wins.
                const auto hit = std::find_if(scanned.begin(), scanned.end(),
                                              [](const Correspondence& c) { return c.model == 100; });
                ASSERT_NE(hit, scanned.end());
                EXPECT_EQ(hit->scene, 200u);
                continue;  // FLANN's kd-tree breaks ties its own way
            }
            if (direction == MatchDirection::model_to_scene && k == 2) continue;  // the tie again
            params.search = MatchSearch::kdtree;
            EXPECT_EQ(scanned, match_descriptors(model, scene, params)) << "k " << k;  // same distances, same bits
        }
    }
}

// On real SHOT descriptors (the carton model's keypoints at the default spacing against those at a
// coarser one): the scan and FLANN's exact kd-tree give identical correspondences, at one thread
// and two.
TEST(Matching, ScanEqualsKdTreeOnRealDescriptors)
{
    MFPC_SHARED_FILE_OR_SKIP(model_path, "milk.pcd");
    const PointCloud cloud = read_cloud(model_path);
    const FeatureParams defaults = RecognitionParams{}.model;
    FeatureParams coarse = defaults;
    coarse.keypoint_radius = 0.02f;
    const Model model = prepare_model(cloud, defaults, "milk.pcd");
    const Model other = prepare_model(cloud, coarse, "milk.pcd");
    ASSERT_GT(model.features.size(), 100u);
    for (const MatchDirection direction : {MatchDirection::model_to_scene, MatchDirection::scene_to_model}) {
        MatchParams params;
        params.direction = direction;
        params.search = MatchSearch::kdtree;
        const auto tree = match_descriptors(model.features, other.features, params);
        ASSERT_GT(tree.size(), 100u);  // measured: 204 scene-to-model
        params.search = MatchSearch::scan;
        for (int threads = 1; threads <= 2; ++threads) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
            EXPECT_EQ(match_descriptors(model.features, other.features, params), tree) << threads << " threads";
        }
    }
}

// The scan skips pairs by a lower bound of their distance (from norms of groups of values): over
// several blocks of data, with distances spread around loose and tight thresholds and with
// sparse descriptors (where that bound is nearly tight), it still finds every brute-force pair;
// an undefined (NaN) descriptor matches nothing.
TEST(Matching, ScanBoundsKeepEveryPairAcrossBlocks)
{
    std::mt19937 rng(11);
    Features model = random_features(70, rng);
    Features scene = random_features(601, rng);
    std::uniform_int_distribution<std::size_t> pick(0, scene.size() - 1);
    for (std::size_t i = 0; i < model.size(); ++i)
        for (const float noise : {0.002f, 0.01f, 0.02f, 0.03f, 0.05f}) plant_near_copy(model, i, scene, pick(rng), noise, rng);
    // Sparse descriptors: all of their weight in a few values.
    for (std::size_t i = 60; i < 70; ++i) {
        std::fill_n(model.descriptors.begin() + std::ptrdiff_t(i * shot_size), shot_size, 0.0f);
        for (std::size_t v = 0; v < 3; ++v) model.descriptors[i * shot_size + (i * 37 + v * 101) % shot_size] = 0.57735f;
        plant_near_copy(model, i, scene, pick(rng), 0.01f, rng);
    }
    const auto brute = [&](const MatchParams& params) { return brute_force(model, scene, params); };
    for (const MatchDirection direction : {MatchDirection::model_to_scene, MatchDirection::scene_to_model}) {
        for (const float threshold : {0.02f, 0.3f, 1.2f}) {
            MatchParams params;
            params.direction = direction;
            params.threshold = threshold;
            const auto expected = brute(params);
            ASSERT_GE(expected.size(), 50u);
            expect_same_pairs(match_descriptors(model, scene, params), expected, "scan");
        }
    }
    // Undefined descriptors on both sides: no pair with them, the others unchanged.
    MatchParams params;
    params.threshold = 0.3f;
    const auto before = match_descriptors(model, scene, params);
    const std::size_t nan_model = 3, nan_scene = 300;
    std::fill_n(model.descriptors.begin() + std::ptrdiff_t(nan_model * shot_size), shot_size, std::nanf(""));
    std::fill_n(scene.descriptors.begin() + std::ptrdiff_t(nan_scene * shot_size), shot_size, std::nanf(""));
    const auto after = match_descriptors(model, scene, params);
    std::vector<Correspondence> kept;
    for (const Correspondence& c : before)
        if (c.model != nan_model && c.scene != nan_scene) kept.push_back(c);
    for (const Correspondence& c : after) {
        EXPECT_NE(c.model, nan_model);
        EXPECT_NE(c.scene, nan_scene);
    }
    // Removing a scene descriptor can promote another into some model descriptor's k best.
    EXPECT_GE(after.size(), kept.size());
    for (const Correspondence& c : kept)
        EXPECT_NE(std::find(after.begin(), after.end(), c), after.end()) << c.model << " " << c.scene;
}

TEST(Matching, EmptySidesFewDescriptorsAndBadParamsAreHandled)
{
    std::mt19937 rng(3);
    const Features some = random_features(5, rng);
    const Features none;
    // k beyond the descriptors there are: every pair (unit vectors are at most 4 apart, squared).
    const Features four = random_features(4, rng);
    MatchParams all;
    all.k = 10;
    all.threshold = 10.0f;
    const auto every = match_descriptors(some, four, all);
    EXPECT_EQ(every.size(), 20u);
    expect_same_pairs(every, brute_force(some, four, all), "k beyond the data");
    EXPECT_TRUE(match_descriptors(some, none, MatchParams{}).empty());
    EXPECT_TRUE(match_descriptors(none, some, MatchParams{}).empty());
    MatchParams bad;
    bad.threshold = 0.0f;
    EXPECT_THROW(match_descriptors(some, some, bad), Error);
    bad = MatchParams{};
    bad.k = 0;
    EXPECT_THROW(match_descriptors(some, some, bad), Error);
}

}  // namespace
}  // namespace mfpc
