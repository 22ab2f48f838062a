#include "mfpc/recognition/ground_truth.hpp"

#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "mfpc/core/error.hpp"

namespace mfpc {

GroundTruth read_ground_truth(const std::filesystem::path& path)
{
    const std::string file = path.string();
    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error(file, "cannot open ground truth file");
    std::stringstream text;
    text << in.rdbuf();

    nlohmann::json json;
    try {
        json = nlohmann::json::parse(text.str());
    } catch (const nlohmann::json::parse_error& e) {
        throw Error(file, std::string("invalid JSON: ") + e.what());
    }
    if (!json.is_object()) throw Error(file, "ground truth must be a JSON object");

    GroundTruth truth;
    if (auto model = json.find("model"); model != json.end()) {
        if (!model->is_string()) throw Error(file + ": model", "must be a string");
        truth.model = model->get<std::string>();
    }
    const auto instances = json.find("instances");
    if (instances == json.end() || !instances->is_array()) {
        throw Error(file + ": instances", "missing, or not an array");
    }
    for (std::size_t i = 0; i < instances->size(); ++i) {
        const std::string key = file + ": instances[" + std::to_string(i) + "]";
        const auto& instance = (*instances)[i];
        if (!instance.is_object()) throw Error(key, "must be an object");
        const auto transform = instance.find("transform");
        if (transform == instance.end() || !transform->is_array()) {
            throw Error(key + ".transform", "missing, or not an array of 16 numbers");
        }
        std::vector<double> values;
        for (const auto& v : *transform) {
            if (!v.is_number()) throw Error(key + ".transform", "holds a value that is not a number");
            values.push_back(v.get<double>());
        }
        GroundTruthInstance out;
        out.transform = pose_from_row_major(values, key + ".transform");
        if (auto object = instance.find("object"); object != instance.end() && object->is_string()) {
            out.object = object->get<std::string>();
        }
        if (auto visible = instance.find("visible_points"); visible != instance.end() && visible->is_number_integer()) {
            out.visible_points = visible->get<long>();
        }
        truth.instances.push_back(std::move(out));
    }
    return truth;
}

}  // namespace mfpc
