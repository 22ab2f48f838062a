// Scoring against ground truth with a symmetric object: a pose a symmetry turn away is right.
#include <numbers>

#include <gtest/gtest.h>

#include "mfpc/recognition/evaluation.hpp"

namespace mfpc {
namespace {

// A model whose centroid is on the z axis, with one keypoint off it.
Model small_model()
{
    Model model;
    model.points = {Point(0.03f, 0, 0), Point(-0.03f, 0, 0), Point(0, 0.02f, 0.1f), Point(0, -0.02f, 0.1f)};
    model.features.keypoints = {Point(0.03f, 0, 0)};
    return model;
}

TEST(Evaluation, SymmetricTurnsAreTrueInstancesAndCorrectCorrespondences)
{
    const Model model = small_model();
    GroundTruth truth;
    GroundTruthInstance instance;
    instance.transform = Pose(Eigen::Translation3f(0.1f, 0.2f, 1.0f));
    truth.instances.push_back(instance);

    // Found half a turn about the model's z axis, with its keypoint matched to the scene point where
    // the symmetric twin of that keypoint lies.
    RecognitionResult result;
    Instance found;
    found.transform = instance.transform * Eigen::AngleAxisf(float(std::numbers::pi), Eigen::Vector3f::UnitZ());
    result.instances.push_back(found);
    result.scene_features.keypoints = {instance.transform * Point(-0.03f, 0, 0)};
    result.correspondences.push_back({0, 0, 0.1f});

    Evaluation plain = evaluate(result, model, truth);
    EXPECT_EQ(plain.instances_true, 0u);
    EXPECT_EQ(plain.instances_false, 1u);
    EXPECT_NEAR(plain.rotation_error_deg[0], 180.0f, 1e-3f);
    EXPECT_EQ(plain.correct_correspondences, 0u);

    truth.instances[0].symmetry_order = 2;
    Evaluation symmetric = evaluate(result, model, truth);
    EXPECT_EQ(symmetric.instances_true, 1u);
    EXPECT_EQ(symmetric.instances_false, 0u);
    EXPECT_NEAR(symmetric.rotation_error_deg[0], 0.0f, 1e-2f);
    EXPECT_EQ(symmetric.correct_correspondences, 1u);
    EXPECT_EQ(symmetric.possible_correspondences, 1u);

    // Any angle (a bottle): a quarter turn is right as well; a tilt is not.
    truth.instances[0].symmetry_order = 0;
    result.instances[0].transform = instance.transform * Eigen::AngleAxisf(0.3f, Eigen::Vector3f::UnitZ());
    EXPECT_EQ(evaluate(result, model, truth).instances_true, 1u);
    result.instances[0].transform = instance.transform * Eigen::AngleAxisf(0.5f, Eigen::Vector3f::UnitX());
    EXPECT_EQ(evaluate(result, model, truth).instances_true, 0u);
}

}  // namespace
}  // namespace mfpc
