// Scoring against ground truth with a symmetric object: a pose a symmetry turn away is right.
#include <numbers>

#include <gtest/gtest.h>

#include "mfpc/recognition/evaluation.hpp"
#include "hollow_cup.hpp"

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

// Precision (Eq. 10) and sensitivity (Eq. 11) on a hand-made set: three model keypoints, one true
// instance (a translation), four scene keypoints, five correspondences.
TEST(Evaluation, CountsPrecisionAndSensitivityByHand)
{
    Model model;
    model.points = {Point(0, 0, 0), Point(0.1f, 0, 0), Point(0, 0.1f, 0)};
    model.features.keypoints = model.points;
    GroundTruth truth;
    GroundTruthInstance instance;
    instance.transform = Pose(Eigen::Translation3f(0, 0, 1));
    truth.instances.push_back(instance);

    RecognitionResult result;
    // Scene keypoints: model keypoints 0 and 1 in place (within 1 cm), one 5 mm off keypoint 2's
    // place, one far from everything.
    result.scene_features.keypoints = {Point(0, 0, 1), Point(0.1f, 0, 1.005f), Point(0.005f, 0.1f, 1), Point(1, 1, 1)};
    result.correspondences = {
        {0, 0, 0.1f},  // correct
        {1, 1, 0.1f},  // correct
        {1, 0, 0.1f},  // wrong: keypoint 1 matched to keypoint 0's place
        {2, 2, 0.1f},  // correct (5 mm off, within the 1 cm tolerance)
        {2, 3, 0.1f},  // wrong: far away
    };
    const Evaluation e = evaluate(result, model, truth);
    EXPECT_EQ(e.correct_correspondences, 3u);
    EXPECT_DOUBLE_EQ(e.correspondence_precision, 3.0 / 5.0);
    // Possible: each of the 3 model keypoints has a scene keypoint within 1 cm of its true place;
    // hit: the distinct (model keypoint, instance) pairs matched correctly, 0, 1 and 2.
    EXPECT_EQ(e.possible_correspondences, 3u);
    EXPECT_DOUBLE_EQ(e.correspondence_sensitivity, 1.0);

    // Without the correct match of keypoint 2: two of three pairs hit.
    result.correspondences.erase(result.correspondences.begin() + 3);
    const Evaluation fewer = evaluate(result, model, truth);
    EXPECT_EQ(fewer.correct_correspondences, 2u);
    EXPECT_DOUBLE_EQ(fewer.correspondence_precision, 2.0 / 4.0);
    EXPECT_DOUBLE_EQ(fewer.correspondence_sensitivity, 2.0 / 3.0);
}

// A cup turned about its body is as right as its truth when the sensor would see the same
// surface: its handle hidden behind it at both poses. When the truth shows the handle and the
// found pose hides it, the pose is wrong, whatever the body says.
TEST(Evaluation, ATurnTheSensorCannotSeeIsTrueAndOneItCanIsFalse)
{
    const test::HollowCup cup = test::hollow_cup();
    Model model;
    model.points = cup.points;
    model.normals = cup.normals;
    auto about_axis = [](float degrees) {
        return Pose(Eigen::AngleAxisf(degrees * float(std::numbers::pi) / 180.0f, Eigen::Vector3f::UnitY()));
    };
    const Pose ahead(Eigen::Translation3f(0.0f, 0.0f, 0.8f));
    GroundTruth truth;
    truth.instances.emplace_back();
    RecognitionResult result;
    result.instances.emplace_back();

    // The handle (model +x) pointing away from the sensor, found turned 20 degrees about the body.
    truth.instances[0].transform = ahead * about_axis(-90.0f);
    result.instances[0].transform = truth.instances[0].transform * about_axis(20.0f);
    const Evaluation hidden = evaluate(result, model, truth);
    EXPECT_EQ(hidden.instances_true, 1u);
    EXPECT_EQ(hidden.instances_true_by_surface, 1u);
    EXPECT_NEAR(hidden.rotation_error_deg[0], 20.0f, 1e-2f);
    EvaluationParams strict;
    strict.surface_agreement = 2.0f;  // off
    EXPECT_EQ(evaluate(result, model, truth, strict).instances_false, 1u);

    // The handle to the side, in view; found with it turned away.
    truth.instances[0].transform = ahead;
    result.instances[0].transform = ahead * about_axis(-90.0f);
    const Evaluation shown = evaluate(result, model, truth);
    EXPECT_EQ(shown.instances_true, 0u);
    EXPECT_EQ(shown.instances_false, 1u);
}

}  // namespace
}  // namespace mfpc
