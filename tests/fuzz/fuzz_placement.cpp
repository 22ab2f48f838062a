// place_foveae() on a small fuzzed scene against a fixed model (the built-in carton sampled every
// 5 mm and prepared once): optionally a tilted table of points and a thinned copy of the model
// above it, then up to 400 fuzzed points on a 5 mm grid in front of the sensor and, optionally, a point
// that is not finite (placement ignores those). The strategy (segments, grid or coarse) and the
// voxel and cluster gap are fuzzed within their valid ranges. Asserts that a result either places
// structures or says why not, that the structures are a config parse_foveation_config accepts
// as written (no fovea outside its outer box), with the levels asked for, and that placing again
// gives the same config.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "fuzz_support.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/placement.hpp"
#include "mfpc/simulation/mesh.hpp"

namespace {

using namespace mfpc;

const Model& carton()
{
    static const Model model = [] {
        const RecognitionParams params;
        return prepare_model(sample_surface(make_builtin_object("carton"), 0.005f, 1), params.model, "carton");
    }();
    return model;
}

// What a placement says, for comparing two of them.
std::string placed_config(const PlacementResult& result)
{
    return result.config.structures.empty() ? "fallback: " + result.fallback : to_json(result.config);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
    const Model& model = carton();
    fuzz::Bytes bytes(data, size);
    const int flags = bytes.byte();
    PlacementParams params;
    const PlacementStrategy strategies[] = {PlacementStrategy::segments, PlacementStrategy::grid,
                                            PlacementStrategy::coarse};
    params.strategy = strategies[bytes.in(0, 2)];
    params.voxel = bytes.grid(0.005f, 0.02f, 3);
    params.cluster_gap = bytes.grid(0.01f, 0.05f, 4);

    PointCloud scene;
    const float table = bytes.grid(0.0f, 0.3f, 12);  // the table's height below the sensor
    if (flags & 1) {
        // A table 60 cm square, 1 m ahead, tilted up to about 11 degrees about x, every 1 cm.
        const float tilt = bytes.grid(-0.2f, 0.2f, 8);
        for (int i = -30; i < 30; ++i)
            for (int k = -30; k < 30; ++k) {
                const float z = 1.0f + 0.01f * float(k);
                scene.points.emplace_back(0.01f * float(i), table + tilt * (z - 1.0f), z);
            }
    }
    if (flags & 2) {
        // The model just above the table (y is down in the sensor's frame), turned about the vertical.
        const float angle = bytes.grid(-3.14159f, 3.14159f, 16);
        const Pose pose = Eigen::Translation3f(bytes.grid(-0.2f, 0.2f, 8), table - 0.1f, bytes.grid(0.8f, 1.2f, 8)) *
                          Eigen::AngleAxisf(angle, Eigen::Vector3f(0, 1, 0));
        const int stride = bytes.in(1, 6);
        for (std::size_t i = 0; i < model.points.size(); i += std::size_t(stride)) scene.points.push_back(pose * model.points[i]);
    }
    const std::size_t limit = scene.size() + 400;
    while (bytes.left() >= 6 && scene.size() < limit) {
        scene.points.emplace_back(bytes.grid(-0.4f, 0.4f, 160), bytes.grid(-0.4f, 0.4f, 160), bytes.grid(0.5f, 1.5f, 200));
    }
    if (flags & 4) scene.points.emplace_back(std::numeric_limits<float>::quiet_NaN(), 0.0f, 1.0f);
    scene.width = std::uint32_t(scene.size());

    fuzz::run([&] {
        const RecognitionParams recognition;
        const Model* const models[] = {&model};
        const PlacementResult result = place_foveae(scene, models, recognition, params);
        const bool placed = !result.config.structures.empty();
        fuzz::check(placed == result.fallback.empty(), "a placement neither places structures nor says why not");
        fuzz::check(std::isfinite(result.ms) && result.ms >= 0, "the placement time is not finite");
        if (placed) {
            for (const FoveatedStructure& s : result.config.structures)
                fuzz::check(s.levels == params.levels, "a structure without the levels asked for");
            // As written, the config reads back, with no fovea outside its outer box.
            try {
                parse_foveation_config(to_json(result.config), "placed", FoveaPolicy::strict);
            } catch (const Error& e) {
                fuzz::fail(std::string("the placed config does not read back: ") + e.what());
            }
        }
        fuzz::check(placed_config(place_foveae(scene, models, recognition, params)) == placed_config(result),
                    "placing the same scene again gives another config");
    });
    return 0;
}
