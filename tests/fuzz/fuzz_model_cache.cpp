// read_model_cache on a fuzzed .mfpcm. Asserts the model it accepts is whole (finite points,
// one normal per point, one frame and 352 finite descriptor values per keypoint, at least 3
// keypoints) and that writing it back and reading that gives the same model.
#include "fuzz_support.hpp"
#include "mfpc/kernels/shot.hpp"
#include "mfpc/recognition/model.hpp"

namespace {

void check_model(const mfpc::Model& model)
{
    using namespace mfpc;
    fuzz::check(!model.points.empty(), "a model cache without points was accepted");
    for (const Point& p : model.points) fuzz::check(fuzz::finite(p), "a model point is not finite");
    fuzz::check(model.normals.size() == model.points.size(), "model normals and points differ in number");
    const Features& features = model.features;
    fuzz::check(features.size() >= 3, "a model with fewer than 3 keypoints was accepted");
    fuzz::check(features.frames.size() == features.size(), "model frames and keypoints differ in number");
    fuzz::check(features.descriptors.size() == features.size() * shot_size, "model descriptors are not 352 per keypoint");
    for (const Point& p : features.keypoints) fuzz::check(fuzz::finite(p), "a model keypoint is not finite");
    for (const LocalReferenceFrame& frame : features.frames) fuzz::check(is_valid(frame), "a model frame is not valid");
    for (float value : features.descriptors) fuzz::check(std::isfinite(value), "a model descriptor is not finite");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    const auto path = fuzz::write_input("in.mfpcm", data, size);
    fuzz::run([&] {
        const Model model = read_model_cache(path);
        check_model(model);
        Model back;
        try {
            write_model_cache(fuzz::scratch_dir() / "out.mfpcm", model);
            back = read_model_cache(fuzz::scratch_dir() / "out.mfpcm");
        } catch (const Error& error) {
            fuzz::fail(std::string("an accepted model cache does not write and read back: ") + error.what());
        }
        fuzz::check(back.points == model.points && back.features.keypoints == model.features.keypoints &&
                        back.features.descriptors == model.features.descriptors,
                    "a model cache changed when written and read back");
    });
    return 0;
}
