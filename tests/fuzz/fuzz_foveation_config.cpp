// parse_foveation_config on fuzzed JSON, under both fovea policies. Asserts what an accepted config
// promises (structures, one m for all, valid level boxes nested inside each other) and that
// to_json writes a text that reads back to the same config, float for float, without new clamps.
#include <string>
#include <string_view>
#include <vector>

#include "fuzz_support.hpp"
#include "mfpc/core/foveation_config.hpp"

namespace {

using namespace mfpc;

bool same_structure(const FoveatedStructure& a, const FoveatedStructure& b)
{
    return a.outer_min == b.outer_min && a.outer_size == b.outer_size && a.fovea_size == b.fovea_size &&
           a.fovea_offset == b.fovea_offset && a.levels == b.levels && a.density_outer == b.density_outer &&
           a.density_fovea == b.density_fovea && a.keypoint_radius_outer == b.keypoint_radius_outer &&
           a.keypoint_radius_fovea == b.keypoint_radius_fovea && a.name == b.name;
}

void check_config(const FoveationConfig& config)
{
    fuzz::check(!config.structures.empty(), "a config without structures was accepted");
    for (const FoveatedStructure& structure : config.structures) {
        fuzz::check(structure.levels == config.levels(), "structures with different m were accepted");
        try {
            Box outer = structure.level_box(0);
            for (int level = 1; level <= structure.levels; ++level) {
                const Box box = structure.level_box(level);
                fuzz::check(outer.contains(box.min) && outer.contains(box.max), "box k + 1 is not inside box k");
                fuzz::check(std::isfinite(structure.density(level)) && structure.density(level) >= 0,
                            "a level density is not a finite size");
                outer = box;
            }
        } catch (const Error& error) {
            fuzz::fail(std::string("an accepted structure has no level boxes: ") + error.what());
        }
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    for (const FoveaPolicy policy : {FoveaPolicy::clamp, FoveaPolicy::strict}) {
        fuzz::run([&] {
            std::vector<std::string> warnings;
            const FoveationConfig config = parse_foveation_config(text, "fuzz.json", policy, &warnings);
            fuzz::check(policy == FoveaPolicy::clamp || warnings.empty(), "strict policy clamped a fovea");
            check_config(config);
            std::string json;
            FoveationConfig back;
            std::vector<std::string> warnings_back;
            try {
                json = to_json(config);
                back = parse_foveation_config(json, "to_json", FoveaPolicy::strict, &warnings_back);
            } catch (const Error& error) {
                fuzz::fail(std::string("an accepted config does not read back from to_json: ") + error.what());
            }
            fuzz::check(back.downsample == config.downsample, "round trip changed the downsampling");
            fuzz::check(back.structures.size() == config.structures.size(), "round trip changed the structures");
            for (std::size_t i = 0; i < config.structures.size(); ++i) {
                fuzz::check(same_structure(back.structures[i], config.structures[i]), "round trip changed a structure");
            }
        });
    }
    return 0;
}
