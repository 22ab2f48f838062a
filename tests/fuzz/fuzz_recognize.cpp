// recognize() on a small fuzzed scene against a fixed model (the built-in carton sampled every
// 5 mm and prepared once): up to 300 fuzzed points on a 5 mm grid in front of the sensor, and
// optionally a thinned copy of the model moved by a fuzzed pose, plain or foveated by a fuzzed
// structure. Asserts consistent counts, correspondences that name existing keypoints, and
// instances whose poses are finite rigid motions supported by their own correspondences.
#include <cmath>
#include <vector>

#include "fuzz_support.hpp"
#include "mfpc/kernels/shot.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/recognize.hpp"
#include "mfpc/simulation/mesh.hpp"

namespace {

using namespace mfpc;

bool rigid(const Pose& pose)
{
    const Eigen::Matrix3f rotation = pose.linear();
    return pose.matrix().allFinite() &&
           (rotation * rotation.transpose() - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff() < 1e-3f;
}

const Model& carton()
{
    static const Model model = [] {
        const RecognitionParams params;
        return prepare_model(sample_surface(make_builtin_object("carton"), 0.005f, 1), params.model, "carton");
    }();
    return model;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const Model& model = carton();
    fuzz::Bytes bytes(data, size);
    RecognitionParams params;
    const int flags = bytes.byte();
    params.scene.resolution = flags & 1 ? 0.005f : 0.0f;
    PointCloud scene;
    if (flags & 2) {
        const float angle = bytes.grid(-3.14159f, 3.14159f, 32);
        const Pose pose = Eigen::Translation3f(bytes.grid(-0.1f, 0.1f, 8), bytes.grid(-0.1f, 0.1f, 8),
                                               bytes.grid(0.7f, 1.2f, 8)) *
                          Eigen::AngleAxisf(angle, Eigen::Vector3f(1, 0, 0));
        const int stride = bytes.in(1, 6);
        for (std::size_t i = 0; i < model.points.size(); i += std::size_t(stride)) scene.points.push_back(pose * model.points[i]);
    }
    FoveationConfig fovea;
    if (flags & 4) {
        FoveatedStructure structure;
        structure.levels = bytes.in(1, 3);
        structure.outer_min = Point(-0.3f, -0.3f, 0.5f);
        structure.outer_size = Point(0.6f, 0.6f, 0.8f);
        structure.fovea_size = structure.outer_size * bytes.grid(0.125f, 1, 7);
        structure.fovea_offset = Point(bytes.grid(-0.2f, 0.2f, 8), bytes.grid(-0.2f, 0.2f, 8), bytes.grid(-0.3f, 0.3f, 8));
        structure.density_outer = bytes.grid(0, 0.02f, 4);
        structure.density_fovea = bytes.grid(0, 0.01f, 4);
        fovea.structures.push_back(structure);
    }
    while (bytes.left() >= 6 && scene.size() < std::size_t(300) + (flags & 2 ? model.points.size() : 0)) {
        scene.points.emplace_back(bytes.grid(-0.2f, 0.2f, 80), bytes.grid(-0.2f, 0.2f, 80), bytes.grid(0.7f, 1.2f, 100));
    }
    if (scene.empty()) return 0;
    scene.width = std::uint32_t(scene.size());

    fuzz::run([&] {
        SceneFoveation foveation;
        if (!fovea.structures.empty()) foveation.config = &fovea;
        const RecognitionResult result = recognize(model, scene, params, foveation);
        const Features& features = result.scene_features;
        fuzz::check(result.counts.scene_keypoints == features.size(), "scene_keypoints is not the described keypoints");
        fuzz::check(result.counts.correspondences == result.correspondences.size(), "correspondences miscounted");
        fuzz::check(features.frames.size() == features.size() && features.descriptors.size() == features.size() * shot_size,
                    "scene features of inconsistent sizes");
        for (const Point& p : features.keypoints) fuzz::check(fuzz::finite(p), "a scene keypoint is not finite");
        for (const Correspondence& c : result.correspondences) {
            fuzz::check(c.model < model.features.size() && c.scene < features.size(), "a correspondence names no keypoint");
            fuzz::check(std::isfinite(c.distance) && c.distance >= 0, "a correspondence distance is not finite");
        }
        for (const Instance& instance : result.instances) {
            fuzz::check(rigid(instance.transform), "an instance pose is not a finite rigid motion");
            fuzz::check(!instance.correspondences.empty(), "an instance without correspondences");
            for (const Correspondence& c : instance.correspondences) {
                fuzz::check(c.model < model.features.size() && c.scene < features.size(),
                            "an instance's correspondence names no keypoint");
            }
            fuzz::check(std::isfinite(instance.votes) && std::isfinite(instance.fitness), "an instance score is not finite");
        }
    });
    return 0;
}
