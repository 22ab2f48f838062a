// read_experiment_config on a fuzzed experiment JSON (its fovea configs may name fovea.json beside
// it, which the target writes once). Asserts what an accepted config promises: strategies with
// unique names, runs in 1..100000, a reference that names a strategy or none, parameters that
// check_recognition_params accepts.
#include <set>

#include "fuzz_support.hpp"
#include "mfpc/recognition/experiment.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    using namespace mfpc;
    static const bool fovea_written = [] {
        const char fovea[] = R"({"levels": 2, "structures": [{"outer_min": [-0.5, -0.5, 0.5], "outer_size": [1, 1, 1],
            "fovea_size": [0.2, 0.2, 0.2], "fovea_offset": [0, 0, 0], "density": [0.02, 0.005], "keypoint_radius": [0.03, 0.01]}]})";
        fuzz::write_input("fovea.json", fovea, sizeof fovea - 1);
        const char params[] = "{}";
        fuzz::write_input("params.json", params, sizeof params - 1);
        return true;
    }();
    (void)fovea_written;
    const auto path = fuzz::write_input("experiment.json", data, size);
    fuzz::run([&] {
        const ExperimentConfig config = read_experiment_config(path);
        fuzz::check(!config.strategies.empty(), "an experiment without strategies was accepted");
        fuzz::check(config.runs >= 1 && config.runs <= 100000, "runs out of 1..100000 accepted");
        fuzz::check(config.reference >= -1 && config.reference < int(config.strategies.size()),
                    "the reference names no strategy");
        std::set<std::string> names;
        for (const ExperimentStrategy& strategy : config.strategies) {
            fuzz::check(names.insert(strategy.name).second, "two strategies of one name accepted");
        }
        try {
            check_recognition_params(config.params, "experiment");
        } catch (const Error& error) {
            fuzz::fail(std::string("an experiment's accepted params do not check: ") + error.what());
        }
    });
    return 0;
}
