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
#include "mfpc/core/point_cloud.hpp"
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

// An array of 3 finite numbers under `name` in `object`.
Eigen::Vector3f read_vector(const json& object, const char* name, const std::string& where)
{
    const std::string key = where + "." + name;
    const auto value = object.find(name);
    if (value == object.end()) throw Error(key, "missing");
    if (!value->is_array() || value->size() != 3 ||
        !std::all_of(value->begin(), value->end(), [](const json& v) { return v.is_number(); }))
        throw Error(key, "must be an array of 3 numbers");
    const Eigen::Vector3f vector((*value)[0].get<float>(), (*value)[1].get<float>(), (*value)[2].get<float>());
    if (!vector.allFinite()) throw Error(key, "must be finite");
    return vector;
}

// read_vector, non-zero, as a unit vector.
Eigen::Vector3f read_direction(const json& object, const char* name, const std::string& where)
{
    const Eigen::Vector3f direction = read_vector(object, name, where);
    if (direction.norm() < 1e-6f) throw Error(where + "." + name, "must be a non-zero vector");
    return direction.normalized();
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
        check_keys(*symmetry, key + ".", {"axis", "order", "flip"});
        out.symmetry_axis = read_direction(*symmetry, "axis", key);
        const auto order = symmetry->find("order");
        if (order == symmetry->end()) throw Error(key + ".order", "missing");
        if (!order->is_number_unsigned() || order->get<std::uint64_t>() > 360)
            throw Error(key + ".order", "must be an integer 0..360 (0: any angle)");
        out.symmetry_order = int(order->get<std::uint64_t>());
        if (const auto flip = symmetry->find("flip"); flip != symmetry->end()) {
            const std::string flip_key = key + ".flip";
            if (!flip->is_object()) throw Error(flip_key, "must be an object {\"axis\": [x, y, z], \"point\": [x, y, z]}");
            check_keys(*flip, flip_key + ".", {"axis", "point"});
            out.flip_axis = read_direction(*flip, "axis", flip_key);
            out.flip_point = read_vector(*flip, "point", flip_key);
            if (!(out.flip_point.cwiseAbs().maxCoeff() <= max_coordinate))
                throw Error(flip_key + ".point", std::string("must lie within +-") + max_coordinate_text);
            // A half-turn about a line across the axis maps the axis onto itself; about any other
            // line the turns and the flip would not be the symmetries of one object.
            if (std::abs(out.flip_axis.dot(out.symmetry_axis)) > 1e-3f)
                throw Error(flip_key + ".axis", "must be perpendicular to the symmetry axis");
            out.symmetry_flip = true;
        }
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
    if (symmetry_flip) {
        // The half-turn about the line through flip_point: x -> R (x - p) + p.
        Pose flip = Pose::Identity();
        flip.linear() = Eigen::AngleAxisf(float(3.14159265358979323846), flip_axis).toRotationMatrix();
        flip.translation() = flip_point - flip.linear() * flip_point;
        for (int k = 0; k < turns; ++k) out.push_back(out[std::size_t(k)] * flip);
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
