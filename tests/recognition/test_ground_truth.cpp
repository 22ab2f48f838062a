#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "mfpc/core/error.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

using test::TempDir;

const std::string identity = "[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]";

// The what() of reading `text` as gt.json in `dir`, after checking that it is one line starting
// with the file's path; "" (and a failure) when it reads.
std::string error_of(const TempDir& dir, const std::string& text)
{
    const auto path = dir.write("scene.gt.json", text);
    try {
        read_ground_truth(path);
    } catch (const Error& error) {
        const std::string what = error.what();
        EXPECT_EQ(what.rfind(path.string() + ": ", 0), 0u) << what;
        EXPECT_EQ(what.find('\n'), std::string::npos) << what;
        return what.substr(path.string().size() + 2);
    }
    ADD_FAILURE() << "read without an error: " << text;
    return {};
}

// A document with one instance holding `members` (after the transform).
std::string one_instance(const std::string& members)
{
    return "{\"model\": \"milk.pcd\", \"instances\": [{\"transform\": " + identity + members + "}]}";
}

TEST(GroundTruth, ReadsTheSharedMilkPair)
{
    MFPC_SHARED_FILE_OR_SKIP(path, "milk_pair.gt.json");
    const GroundTruth truth = read_ground_truth(path);
    EXPECT_EQ(truth.model, "milk.pcd");
    ASSERT_EQ(truth.instances.size(), 2u);
    EXPECT_TRUE(truth.instances[0].transform.isApprox(Pose::Identity()));
    EXPECT_FALSE(truth.instances[1].transform.isApprox(Pose::Identity()));
    EXPECT_NEAR(truth.instances[1].transform.translation().x(), 0.416972f, 1e-6f);
    EXPECT_EQ(truth.instances[0].visible_points, -1);
    EXPECT_TRUE(truth.instances[0].object.empty());
}

TEST(GroundTruth, ReadsTheOptionalInstanceKeys)
{
    TempDir dir;
    const auto path = dir.write("scene.gt.json", one_instance(", \"object\": \"milk\", \"visible_points\": 1234"));
    const GroundTruth truth = read_ground_truth(path);
    ASSERT_EQ(truth.instances.size(), 1u);
    EXPECT_EQ(truth.instances[0].object, "milk");
    EXPECT_EQ(truth.instances[0].visible_points, 1234);
    EXPECT_EQ(read_ground_truth(dir.write("none.gt.json", "{\"instances\": []}")).instances.size(), 0u);
}

TEST(GroundTruth, FileProblemsNameTheFile)
{
    TempDir dir;
    const auto what_of = [](const std::filesystem::path& path) -> std::string {
        try {
            read_ground_truth(path);
        } catch (const Error& error) {
            return error.what();
        }
        return "read without an error";
    };
    EXPECT_EQ(what_of(dir / "absent.gt.json"), (dir / "absent.gt.json").string() + ": no such file");
    std::filesystem::create_directory(dir / "folder.gt.json");
    EXPECT_EQ(what_of(dir / "folder.gt.json"), (dir / "folder.gt.json").string() + ": is a directory");
}

TEST(GroundTruth, RejectsInvalidJson)
{
    TempDir dir;
    // nlohmann's "[json.exception.parse_error.101] " prefix is left out.
    const std::string syntax = error_of(dir, "{\"instances\": [\n}");
    EXPECT_EQ(syntax.rfind("invalid JSON: parse error at line 2", 0), 0u) << syntax;
    EXPECT_EQ(error_of(dir, "").rfind("invalid JSON: ", 0), 0u);
    // A number beyond double is nlohmann's out_of_range, not a parse_error.
    EXPECT_EQ(error_of(dir, one_instance(", \"visible_points\": 1e999")),
              "invalid JSON: number overflow parsing '1e999'");
    EXPECT_EQ(error_of(dir, "[1, 2]"), "ground truth must be a JSON object");
}

// Keys given twice and deep nesting are refused as every MFPC JSON reader refuses them
// (check_json_text; its own tests are in tests/core).
TEST(GroundTruth, RejectsDuplicateKeysAndDeepNesting)
{
    TempDir dir;
    EXPECT_EQ(error_of(dir, one_instance(", \"object\": \"a\", \"object\": \"b\"")),
              "instances[0].object: duplicate key");
    EXPECT_EQ(error_of(dir, "{\"instances\": [], \"instances\": []}"), "instances: duplicate key");
    EXPECT_EQ(error_of(dir, "{\"instances\": " + std::string(100, '[') + std::string(100, ']') + "}"),
              "invalid JSON: nested deeper than 64 levels");
}

TEST(GroundTruth, RejectsBadTransforms)
{
    TempDir dir;
    const auto with_transform = [](const std::string& transform) {
        return "{\"instances\": [{\"transform\": " + identity + "}, {\"transform\": " + transform + "}]}";
    };
    EXPECT_EQ(error_of(dir, with_transform("[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0]")),
              "instances[1].transform: a pose needs 16 numbers (row-major 4x4), got 15");
    EXPECT_EQ(error_of(dir, with_transform("[2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]")),
              "instances[1].transform: rotation block of the pose is not a rotation (orthonormal, determinant +1)");
    EXPECT_EQ(error_of(dir, with_transform("[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 1]")),
              "instances[1].transform: last row of the pose is not (0 0 0 1)");
    EXPECT_EQ(error_of(dir, with_transform("[1, 0, 0, 1e300, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]")),
              "instances[1].transform[3]: beyond the float range");
    EXPECT_EQ(error_of(dir, with_transform("[1, 0, 0, \"0\", 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]")),
              "instances[1].transform[3]: must be a number, not string");
    EXPECT_EQ(error_of(dir, with_transform("\"identity\"")), "instances[1].transform: must be an array of 16 numbers");
    EXPECT_EQ(error_of(dir, "{\"instances\": [{\"object\": \"milk\"}]}"), "instances[0].transform: missing");
}

TEST(GroundTruth, RejectsWrongTypes)
{
    TempDir dir;
    EXPECT_EQ(error_of(dir, "{\"model\": 3, \"instances\": []}"), "model: must be a string, not number");
    EXPECT_EQ(error_of(dir, "{\"model\": \"milk.pcd\"}"), "instances: missing");
    EXPECT_EQ(error_of(dir, "{\"instances\": {}}"), "instances: must be an array");
    EXPECT_EQ(error_of(dir, "{\"instances\": [7]}"), "instances[0]: must be an object");
    EXPECT_EQ(error_of(dir, one_instance(", \"object\": 7")), "instances[0].object: must be a string, not number");
    EXPECT_EQ(error_of(dir, one_instance(", \"object\": null")), "instances[0].object: must be a string, not null");
    for (const std::string count : {"12.5", "-3", "\"12\"", "true", "9223372036854775808"}) {
        SCOPED_TRACE(count);
        EXPECT_EQ(error_of(dir, one_instance(", \"visible_points\": " + count)),
                  "instances[0].visible_points: must be a non-negative integer");
    }
}

TEST(GroundTruth, RejectsUnknownKeys)
{
    TempDir dir;
    EXPECT_EQ(error_of(dir, "{\"instances\": [], \"scene\": \"a.pcd\"}"), "scene: unknown key");
    EXPECT_EQ(error_of(dir, one_instance(", \"pose\": 1")), "instances[0].pose: unknown key");
    // A key that is not a plain name is quoted, JSON-escaped, so the message stays one line.
    EXPECT_EQ(error_of(dir, one_instance(", \"vis\\nible\": 1")), "instances[0].\"vis\\nible\": unknown key");
    EXPECT_EQ(error_of(dir, "{\"instances\": [], \"a.b\": 1}"), "\"a.b\": unknown key");
}

TEST(GroundTruth, ReadsASymmetryAndItsEquivalentTransforms)
{
    TempDir dir;
    const auto path = dir.write("scene.gt.json", one_instance(", \"symmetry\": {\"axis\": [0, 0, 2], \"order\": 2}"));
    const GroundTruth truth = read_ground_truth(path);
    ASSERT_EQ(truth.instances.size(), 1u);
    EXPECT_EQ(truth.instances[0].symmetry_order, 2);
    EXPECT_TRUE(truth.instances[0].symmetry_axis.isApprox(Eigen::Vector3f::UnitZ()));
    const std::vector<Pose> equivalent = truth.instances[0].equivalent_transforms();
    ASSERT_EQ(equivalent.size(), 2u);
    EXPECT_TRUE(equivalent[0].isApprox(Pose::Identity()));
    // Half a turn about z: x -> -x, y -> -y.
    EXPECT_TRUE((equivalent[1] * Eigen::Vector3f(1, 2, 3)).isApprox(Eigen::Vector3f(-1, -2, 3), 1e-6f));

    GroundTruthInstance bottle;
    bottle.symmetry_order = 0;  // any angle: sampled every degree
    EXPECT_EQ(bottle.equivalent_transforms().size(), 360u);
    EXPECT_EQ(GroundTruthInstance{}.equivalent_transforms().size(), 1u);
}

TEST(GroundTruth, ReadsAFlipAndItsDihedralTransforms)
{
    // A box 26 cm tall standing on its origin: a half-turn about z, and one about the x axis
    // through its mid-height (upside down, in place).
    TempDir dir;
    const auto path = dir.write(
        "scene.gt.json",
        one_instance(", \"symmetry\": {\"axis\": [0, 0, 1], \"order\": 2, \"flip\": {\"axis\": [2, 0, 0], \"point\": [0, 0, 0.13]}}"));
    const GroundTruthInstance box = read_ground_truth(path).instances.at(0);
    EXPECT_TRUE(box.symmetry_flip);
    EXPECT_TRUE(box.flip_axis.isApprox(Eigen::Vector3f::UnitX()));
    const std::vector<Pose> equivalent = box.equivalent_transforms();
    ASSERT_EQ(equivalent.size(), 4u);
    // Upside down about the mid-height: the bottom centre goes to the top centre, and back.
    EXPECT_TRUE((equivalent[2] * Eigen::Vector3f(0, 0, 0)).isApprox(Eigen::Vector3f(0, 0, 0.26f), 1e-6f));
    EXPECT_TRUE((equivalent[2] * Eigen::Vector3f(0.1f, 0.02f, 0.26f)).isApprox(Eigen::Vector3f(0.1f, -0.02f, 0), 1e-6f));
    // Both half-turns: the third axis, y, through the mid-height.
    EXPECT_TRUE((equivalent[3] * Eigen::Vector3f(0.1f, 0.02f, 0.26f)).isApprox(Eigen::Vector3f(-0.1f, 0.02f, 0), 1e-6f));
}

TEST(GroundTruth, RejectsBadSymmetries)
{
    TempDir dir;
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": 2")), "instances[0].symmetry: must be an object {\"axis\": [x, y, z], \"order\": N}");
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": {\"order\": 2}")), "instances[0].symmetry.axis: missing");
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": {\"axis\": [0, 0, 1]}")), "instances[0].symmetry.order: missing");
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": {\"axis\": [0, 0], \"order\": 2}")),
              "instances[0].symmetry.axis: must be an array of 3 numbers");
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": {\"axis\": [0, 0, 0], \"order\": 2}")),
              "instances[0].symmetry.axis: must be a non-zero vector");
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": {\"axis\": [0, 0, 1], \"order\": -2}")),
              "instances[0].symmetry.order: must be an integer 0..360 (0: any angle)");
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": {\"axis\": [0, 0, 1], \"order\": 2, \"about\": 1}")),
              "instances[0].symmetry.about: unknown key");
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": {\"axis\": [0, 0, 1], \"order\": 2, \"flip\": 1}")),
              "instances[0].symmetry.flip: must be an object {\"axis\": [x, y, z], \"point\": [x, y, z]}");
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": {\"axis\": [0, 0, 1], \"order\": 2, \"flip\": {\"axis\": [1, 0, 0]}}")),
              "instances[0].symmetry.flip.point: missing");
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": {\"axis\": [0, 0, 1], \"order\": 2, \"flip\": {\"axis\": [1, 0, 1], \"point\": [0, 0, 0]}}")),
              "instances[0].symmetry.flip.axis: must be perpendicular to the symmetry axis");
    EXPECT_EQ(error_of(dir, one_instance(", \"symmetry\": {\"axis\": [0, 0, 1], \"order\": 2, \"flip\": {\"axis\": [1, 0, 0], \"point\": [0, 0, 3e38]}}")),
              "instances[0].symmetry.flip.point: must lie within +-1e9");
}

}  // namespace
}  // namespace mfpc
