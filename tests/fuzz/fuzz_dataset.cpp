// read_dataset on a fuzzed manifest. Files are not opened by the reader; asserts the set it accepts
// has models and scenes, unique names, and scenes that each name one of its models.
#include <set>

#include "fuzz_support.hpp"
#include "mfpc/recognition/dataset.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    const auto path = fuzz::write_input("set.json", data, size);
    fuzz::run([&] {
        const Dataset set = read_dataset(path);
        fuzz::check(!set.models.empty() && !set.scenes.empty(), "a set without models or scenes was accepted");
        std::set<std::string> models, scenes;
        for (const DatasetModel& model : set.models) fuzz::check(models.insert(model.name).second, "two models of one name");
        for (const DatasetScene& scene : set.scenes) {
            fuzz::check(scenes.insert(scene.name).second, "two scenes of one name");
            fuzz::check(models.count(scene.model) == 1, "a scene names a model the set lacks");
        }
    });
    return 0;
}
