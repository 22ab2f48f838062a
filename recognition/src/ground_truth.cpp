#include "mfpc/recognition/ground_truth.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/json_check.hpp"
#include "mfpc/core/detail/text_file.hpp"

namespace mfpc {

namespace {

using nlohmann::json;

// A key of the file as it goes into a key path: a plain name as it is, anything else JSON-escaped
// in quotes (at most 60 bytes of it), so that a key holding a newline cannot make a message two
// lines, nor a key holding '.' or ": " pose as a path. (The foveation config reader does the
// same with core's private quoting helper.)
std::string key_text(const std::string& key)
{
    constexpr std::size_t longest = 60;
    const bool plain = !key.empty() && key.size() <= longest && std::all_of(key.begin(), key.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-';
    });
    if (plain) return key;
    const std::string shown = key.size() > longest ? key.substr(0, longest) + "..." : key;
    return json(shown).dump(-1, ' ', true, json::error_handler_t::replace);
}

// `prefix` is what comes before a key in its path: "file: " or "file: instances[0].".
void check_keys(const json& object, const std::string& prefix, std::initializer_list<const char*> allowed)
{
    for (const auto& item : object.items()) {
        bool known = false;
        for (const char* name : allowed) known = known || item.key() == name;
        if (!known) throw Error(prefix + key_text(item.key()), "unknown key");
    }
}

GroundTruthInstance read_instance(const json& instance, const std::string& where)
{
    if (!instance.is_object()) throw Error(where, "must be an object");
    check_keys(instance, where + ".", {"transform", "object", "visible_points", "visible_fraction", "symmetry"});

    GroundTruthInstance out;
    const auto transform = instance.find("transform");
    if (transform == instance.end()) throw Error(where + ".transform", "missing");
    if (!transform->is_array()) throw Error(where + ".transform", "must be an array of 16 numbers");
    std::vector<double> values;
    for (std::size_t i = 0; i < transform->size(); ++i) {
        const json& value = (*transform)[i];
        const std::string element = where + ".transform[" + std::to_string(i) + "]";
        if (!value.is_number()) throw Error(element, std::string("must be a number, not ") + value.type_name());
        // The pose is stored in float; a larger number would not survive the conversion.
        if (!(std::abs(value.get<double>()) <= std::numeric_limits<float>::max())) {
            throw Error(element, "beyond the float range");
        }
        values.push_back(value.get<double>());
    }
    out.transform = pose_from_row_major(values, where + ".transform");

    if (const auto object = instance.find("object"); object != instance.end()) {
        if (!object->is_string()) throw Error(where + ".object", std::string("must be a string, not ") + object->type_name());
        out.object = object->get<std::string>();
    }
    if (const auto visible = instance.find("visible_points"); visible != instance.end()) {
        // -1 is how GroundTruthInstance says "not given", so a count is never negative.
        const bool count = visible->is_number_unsigned() &&
                           visible->get<std::uint64_t>() <= std::uint64_t(std::numeric_limits<long>::max());
        if (!count) throw Error(where + ".visible_points", "must be a non-negative integer");
        out.visible_points = visible->get<long>();
    }
    if (const auto fraction = instance.find("visible_fraction"); fraction != instance.end()) {
        if (!fraction->is_number() || !(fraction->get<double>() >= 0.0 && fraction->get<double>() <= 1.0))
            throw Error(where + ".visible_fraction", "must be a number in 0..1");
        out.visible_fraction = fraction->get<float>();
    }
    if (const auto symmetry = instance.find("symmetry"); symmetry != instance.end()) {
        const std::string key = where + ".symmetry";
        if (!symmetry->is_object()) throw Error(key, "must be an object {\"axis\": [x, y, z], \"order\": N}");
        check_keys(*symmetry, key + ".", {"axis", "order"});
        const auto axis = symmetry->find("axis");
        const auto order = symmetry->find("order");
        if (axis == symmetry->end()) throw Error(key + ".axis", "missing");
        if (order == symmetry->end()) throw Error(key + ".order", "missing");
        if (!axis->is_array() || axis->size() != 3 ||
            !std::all_of(axis->begin(), axis->end(), [](const json& v) { return v.is_number(); }))
            throw Error(key + ".axis", "must be an array of 3 numbers");
        const Eigen::Vector3f direction((*axis)[0].get<float>(), (*axis)[1].get<float>(), (*axis)[2].get<float>());
        if (!direction.allFinite() || direction.norm() < 1e-6f) throw Error(key + ".axis", "must be a non-zero vector");
        if (!order->is_number_unsigned() || order->get<std::uint64_t>() > 360)
            throw Error(key + ".order", "must be an integer 0..360 (0: any angle)");
        out.symmetry_axis = direction.normalized();
        out.symmetry_order = int(order->get<std::uint64_t>());
    }
    return out;
}

}  // namespace

std::vector<Pose> GroundTruthInstance::equivalent_transforms() const
{
    const int turns = symmetry_order == 0 ? 360 : std::max(symmetry_order, 1);
    std::vector<Pose> out;
    for (int k = 0; k < turns; ++k) {
        const float angle = float(2.0 * 3.14159265358979323846 * k / turns);
        out.push_back(transform * Eigen::AngleAxisf(angle, symmetry_axis));
    }
    return out;
}

GroundTruth read_ground_truth(const std::filesystem::path& path)
{
    const std::string file = path.string();
    const std::string text = read_text_file(path);
    // Duplicate keys, deep nesting and syntax errors, named the way every JSON reader names them;
    // the text is then known to parse.
    check_json_text(text, file);
    const json root = json::parse(text);
    if (!root.is_object()) throw Error(file, "ground truth must be a JSON object");
    check_keys(root, file + ": ", {"model", "instances"});

    GroundTruth truth;
    if (const auto model = root.find("model"); model != root.end()) {
        if (!model->is_string()) throw Error(file + ": model", std::string("must be a string, not ") + model->type_name());
        truth.model = model->get<std::string>();
    }
    const auto instances = root.find("instances");
    if (instances == root.end()) throw Error(file + ": instances", "missing");
    if (!instances->is_array()) throw Error(file + ": instances", "must be an array");
    for (std::size_t i = 0; i < instances->size(); ++i) {
        truth.instances.push_back(read_instance((*instances)[i], file + ": instances[" + std::to_string(i) + "]"));
    }
    return truth;
}

}  // namespace mfpc
