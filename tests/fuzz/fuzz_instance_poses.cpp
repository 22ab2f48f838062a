// read_instance_poses (the instances a render overlays, from a recognize JSON report) on fuzzed
// JSON. Asserts at most max_instance_poses poses, each finite and rigid.
#include "fuzz_support.hpp"
#include "mfpc/recognition/recognition_report.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    const auto path = fuzz::write_input("instances.json", data, size);
    fuzz::run([&] {
        const InstancePoses poses = read_instance_poses(path);
        fuzz::check(poses.transforms.size() <= max_instance_poses, "more than max_instance_poses accepted");
        for (const Pose& pose : poses.transforms) {
            fuzz::check(pose.matrix().allFinite(), "an instance pose is not finite");
            const Eigen::Matrix3f rotation = pose.linear();
            fuzz::check((rotation * rotation.transpose() - Eigen::Matrix3f::Identity()).cwiseAbs().maxCoeff() < 1e-3f,
                        "an instance pose is not rigid");
        }
    });
    return 0;
}
