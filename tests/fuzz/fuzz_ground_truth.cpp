// read_ground_truth on a fuzzed *.gt.json. Asserts that every accepted pose is rigid and finite
// and that the equivalent poses of its symmetry are too.
#include "fuzz_support.hpp"
#include "mfpc/recognition/ground_truth.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    const auto path = fuzz::write_input("scene.gt.json", data, size);
    fuzz::run([&] {
        const GroundTruth truth = read_ground_truth(path);
        for (const GroundTruthInstance& instance : truth.instances) {
            fuzz::check(instance.transform.matrix().allFinite(), "a ground-truth pose is not finite");
            const Eigen::Matrix3f rotation = instance.transform.linear();
            fuzz::check((rotation * rotation.transpose() - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff() < 1e-3f,
                        "a ground-truth pose is not rigid");
            fuzz::check(instance.symmetry_order >= 0, "negative symmetry order accepted");
            fuzz::check(instance.symmetry_axis.allFinite(), "a symmetry axis is not finite");
            const auto poses = instance.equivalent_transforms();
            const std::size_t turns = instance.symmetry_order == 0 ? 360 : std::size_t(instance.symmetry_order);
            fuzz::check(poses.size() == turns * (instance.symmetry_flip ? 2 : 1),
                        "not one equivalent pose per turn of the symmetry (twice with a flip)");
            fuzz::check(!instance.symmetry_flip || (instance.flip_axis.allFinite() && instance.flip_point.allFinite()),
                        "a flip line is not finite");
            for (const Pose& pose : poses) fuzz::check(pose.matrix().allFinite(), "an equivalent pose is not finite");
        }
    });
    return 0;
}
