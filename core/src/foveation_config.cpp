#include "mfpc/core/foveation_config.hpp"

#include <charconv>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cloud_format.hpp"  // quoted, narrow_to_float
#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/json_check.hpp"
#include "mfpc/core/detail/text_file.hpp"

namespace mfpc {

namespace {

using nlohmann::json;

// RegionLabel stores structure and level in 16 bits.
constexpr std::int64_t max_label = std::numeric_limits<std::int16_t>::max();

const char* const axis_names[] = {"x", "y", "z"};

// How the parser reads a number: JSON numbers are read as double (nlohmann uses the correctly
// rounded strtod), then rounded to float where a float is stored.
double read_back(const std::string& text)
{
    double value = 0.0;
    std::from_chars(text.data(), text.data() + text.size(), value);
    return value;
}

// F from a fovea centre as written in a config: (c - Δ) - S_0/2 in double, rounded once (the same
// order as FoveatedStructure::set_fovea_center). to_json checks its centres with this very function.
float offset_from_center(double center, float outer_min, float outer_size)
{
    // Centre and box are each within float range, but their difference need not be.
    return detail::narrow_to_float(center - double(outer_min) - 0.5 * double(outer_size));
}

// Reads one config; every error names the source and the key path.
class Reader {
public:
    Reader(const std::string& source, FoveaPolicy policy, std::vector<std::string>* warnings)
        : source_(source), policy_(policy), warnings_(warnings)
    {
    }

    [[noreturn]] void fail(const std::string& key, const std::string& reason) const
    {
        throw Error(key.empty() ? source_ : source_ + ": " + key, reason);
    }

    void check_keys(const json& object, const std::string& key,
                    std::initializer_list<const char*> allowed) const
    {
        for (const auto& item : object.items()) {
            bool known = false;
            for (const char* name : allowed) known = known || item.key() == name;
            if (!known) fail(join(key, item.key()), "unknown key");
        }
    }

    static std::string join(const std::string& key, const std::string& member)
    {
        return key.empty() ? json_key_text(member) : key + "." + json_key_text(member);
    }

    float read_float(const json& value, const std::string& key) const
    {
        if (!value.is_number()) {
            fail(key, std::string("must be a number, not ") + value.type_name());
        }
        const double number = value.get<double>();
        const float result = detail::narrow_to_float(number);
        if (!std::isfinite(result)) {
            fail(key, "must be a finite number in float range");
        }
        return result;
    }

    std::vector<double> read_numbers(const json& value, const std::string& key,
                                     std::size_t count) const
    {
        if (!value.is_array() || value.size() != count) {
            fail(key, "must be an array of " + std::to_string(count) + " numbers");
        }
        std::vector<double> numbers;
        for (std::size_t i = 0; i < count; ++i) {
            const std::string element_key = key + "[" + std::to_string(i) + "]";
            read_float(value[i], element_key);  // type and range check
            numbers.push_back(value[i].get<double>());
        }
        return numbers;
    }

    Eigen::Vector3f read_vector(const json& value, const std::string& key) const
    {
        const std::vector<double> numbers = read_numbers(value, key, 3);
        return Eigen::Vector3f(detail::narrow_to_float(numbers[0]), detail::narrow_to_float(numbers[1]),
                               detail::narrow_to_float(numbers[2]));
    }

    Eigen::Vector3f read_size(const json& value, const std::string& key) const
    {
        const Eigen::Vector3f size = read_vector(value, key);
        for (int axis = 0; axis < 3; ++axis) {
            if (!(size[axis] > 0.0f)) {
                fail(key, std::string("size must be positive, ") + axis_names[axis] + " is " +
                              format_number(size[axis]));
            }
        }
        return size;
    }

    int read_levels(const json& value, const std::string& key) const
    {
        if (!value.is_number_integer()) {
            fail(key, std::string("must be an integer, not ") + value.type_name());
        }
        if (value.is_number_unsigned() && value.get<std::uint64_t>() > std::uint64_t(max_levels)) {
            fail(key, "at most " + std::to_string(max_levels) + " levels are supported");
        }
        const std::int64_t levels = value.get<std::int64_t>();
        if (levels < 1) fail(key, "needs at least 1 level, got " + std::to_string(levels));
        if (levels > max_levels) {
            fail(key, "at most " + std::to_string(max_levels) + " levels are supported");
        }
        return static_cast<int>(levels);
    }

    FoveationConfig read(const json& root)
    {
        if (!root.is_object()) fail("", "a foveation config must be a JSON object");
        check_keys(root, "", {"levels", "downsample", "structures"});

        FoveationConfig config;
        if (!root.contains("levels")) fail("levels", "missing (the number of levels m)");
        const int levels = read_levels(root["levels"], "levels");

        if (root.contains("downsample")) {
            const json& value = root["downsample"];
            if (!value.is_string()) fail("downsample", "must be a string: voxel or uniform");
            config.downsample = parse_downsample(value.get<std::string>(), source_ + ": downsample");
        }

        if (!root.contains("structures")) fail("structures", "missing");
        const json& structures = root["structures"];
        if (!structures.is_array()) fail("structures", "must be an array of structures");
        if (structures.empty()) fail("structures", "needs at least one structure");
        if (structures.size() > std::size_t(max_label)) {
            fail("structures", "at most " + std::to_string(max_label) + " structures are supported");
        }
        for (std::size_t i = 0; i < structures.size(); ++i) {
            config.structures.push_back(
                read_structure(structures[i], "structures[" + std::to_string(i) + "]", levels));
        }
        return config;
    }

    FoveatedStructure read_structure(const json& value, const std::string& key, int levels)
    {
        if (!value.is_object()) fail(key, "must be an object");
        check_keys(value, key,
                   {"name", "levels", "outer_min", "outer_size", "fovea_size", "fovea_center",
                    "fovea_offset", "density", "keypoint_radius"});
        const auto required = [&](const char* member) -> const json& {
            if (!value.contains(member)) fail(join(key, member), "missing");
            return value[member];
        };

        FoveatedStructure structure;
        structure.levels = levels;
        if (value.contains("name")) {
            if (!value["name"].is_string()) fail(join(key, "name"), "must be a string");
            structure.name = value["name"].get<std::string>();
        }
        if (value.contains("levels")) {
            // Paper Section 4.2: the redundancy treatment compares levels across structures, so
            // every structure has the same m.
            const int own = read_levels(value["levels"], join(key, "levels"));
            if (own != levels) {
                fail(join(key, "levels"), "structures with different levels: " + std::to_string(own) +
                                              " here, " + std::to_string(levels) + " in the config");
            }
        }

        structure.outer_min = read_vector(required("outer_min"), join(key, "outer_min"));
        structure.outer_size = read_size(required("outer_size"), join(key, "outer_size"));
        if (!structure.outer_box().max.allFinite()) {
            fail(join(key, "outer_size"), "the outer box reaches past the float range");
        }
        structure.fovea_size = read_size(required("fovea_size"), join(key, "fovea_size"));
        for (int axis = 0; axis < 3; ++axis) {
            if (structure.fovea_size[axis] > structure.outer_size[axis]) {
                fail(join(key, "fovea_size"),
                     std::string("fovea bigger than the outer box on ") + axis_names[axis] + " (" +
                         format_number(structure.fovea_size[axis]) + " > " +
                         format_number(structure.outer_size[axis]) + ")");
            }
        }

        const bool has_center = value.contains("fovea_center");
        const bool has_offset = value.contains("fovea_offset");
        if (has_center && has_offset) fail(key, "gives both fovea_center and fovea_offset; give one");
        if (!has_center && !has_offset) fail(key, "needs fovea_center or fovea_offset");
        const std::string fovea_key = join(key, has_center ? "fovea_center" : "fovea_offset");
        const std::vector<double> fovea = read_numbers(value[has_center ? "fovea_center" : "fovea_offset"],
                                                       fovea_key, 3);
        for (int axis = 0; axis < 3; ++axis) {
            // The centre is converted in double from the number as written, rounded once, so
            // to_json can write a centre that reads back to the same F.
            structure.fovea_offset[axis] =
                has_center ? offset_from_center(fovea[axis], structure.outer_min[axis],
                                                structure.outer_size[axis])
                           : detail::narrow_to_float(fovea[axis]);
        }
        keep_fovea_inside(structure, fovea_key, has_center);

        const std::vector<double> density = read_numbers(required("density"), join(key, "density"), 2);
        for (std::size_t i = 0; i < 2; ++i) {
            if (density[i] < 0.0) {
                fail(join(key, "density") + "[" + std::to_string(i) + "]",
                     "must not be negative (0 keeps every point)");
            }
        }
        structure.density_outer = detail::narrow_to_float(density[0]);
        structure.density_fovea = detail::narrow_to_float(density[1]);

        const std::vector<double> radius =
            read_numbers(required("keypoint_radius"), join(key, "keypoint_radius"), 2);
        for (std::size_t i = 0; i < 2; ++i) {
            if (!(detail::narrow_to_float(radius[i]) > 0.0f)) {
                fail(join(key, "keypoint_radius") + "[" + std::to_string(i) + "]", "must be positive");
            }
        }
        structure.keypoint_radius_outer = detail::narrow_to_float(radius[0]);
        structure.keypoint_radius_fovea = detail::narrow_to_float(radius[1]);
        return structure;
    }

    // |F| <= (S_0 - S_m)/2 per axis, or the fovea pokes out of its outer box.
    void keep_fovea_inside(FoveatedStructure& structure, const std::string& key, bool has_center) const
    {
        const Eigen::Vector3f limit = structure.fovea_offset_limit();
        for (int axis = 0; axis < 3; ++axis) {
            const float offset = structure.fovea_offset[axis];
            if (std::abs(offset) <= limit[axis]) continue;
            // A fovea flush with its outer box (a centre written as the box's edge minus half the
            // fovea) lands a few float roundings beyond the limit: that is on the face, not out.
            const float scale = std::abs(structure.outer_min[axis]) + structure.outer_size[axis];
            if (std::abs(offset) - limit[axis] <= 8.0f * std::numeric_limits<float>::epsilon() * scale) {
                structure.fovea_offset[axis] = offset > 0.0f ? limit[axis] : -limit[axis];
                continue;
            }
            const float clamped = offset > 0.0f ? limit[axis] : -limit[axis];
            std::string what = std::string("fovea outside the outer box on ") + axis_names[axis] +
                               ": offset " + format_number(offset) + " beyond ±" +
                               format_number(limit[axis]);
            if (policy_ == FoveaPolicy::strict) fail(key, what);
            structure.fovea_offset[axis] = clamped;
            what += ", clamped to " + format_number(clamped);
            if (has_center) what += " (centre " + format_number(structure.fovea_center()[axis]) + ")";
            if (warnings_) warnings_->push_back(source_ + ": " + key + ": " + what);
        }
    }

private:
    const std::string& source_;
    FoveaPolicy policy_;
    std::vector<std::string>* warnings_;
};

// A float as JSON text that parse_foveation_config reads back to exactly `value`: the shortest
// float text where reading it as double and rounding to float gives `value` back (always, in
// practice), else the shortest double text of `value`, which reads back exactly.
std::string json_number(float value)
{
    if (!std::isfinite(value)) throw Error("foveation config", "non-finite number cannot be written");
    const std::string shortest = format_number(value);
    if (detail::narrow_to_float(read_back(shortest)) == value) return shortest;
    return format_number(double(value));
}

std::string json_vector(const Eigen::Vector3f& value)
{
    return "[" + json_number(value.x()) + ", " + json_number(value.y()) + ", " +
           json_number(value.z()) + "]";
}

// The fovea as "fovea_center" text that the parser turns back into exactly F, or the empty string
// when no centre can say it (F far below the resolution of Δ + S_0/2).
std::string json_fovea_center(const FoveatedStructure& structure)
{
    std::string text = "[";
    for (int axis = 0; axis < 3; ++axis) {
        const float outer_min = structure.outer_min[axis];
        const float outer_size = structure.outer_size[axis];
        const double base = double(outer_min) + 0.5 * double(outer_size);
        const float offset = structure.fovea_offset[axis];
        const auto reads_back = [&](const std::string& candidate) {
            return offset_from_center(read_back(candidate), outer_min, outer_size) == offset;
        };
        // The float centre is the tidy one (what a person would write); the double centre is exact
        // when Δ, S_0/2 and F sum without rounding in double.
        std::string candidate = format_number(structure.fovea_center()[axis]);
        if (!reads_back(candidate)) candidate = format_number(base + double(offset));
        if (!reads_back(candidate)) return {};
        text += (axis ? ", " : "") + candidate;
    }
    return text + "]";
}

}  // namespace

FoveationConfig parse_foveation_config(std::string_view json_text, const std::string& source,
                                       FoveaPolicy policy, std::vector<std::string>* warnings)
{
    // Duplicate keys, deep nesting and syntax errors, named the way every JSON reader names them;
    // the text is then known to parse.
    check_json_text(json_text, source);
    return Reader(source, policy, warnings).read(json::parse(json_text.begin(), json_text.end()));
}

FoveationConfig read_foveation_config(const std::filesystem::path& path, FoveaPolicy policy,
                                      std::vector<std::string>* warnings)
{
    return parse_foveation_config(read_text_file(path), path.string(), policy, warnings);
}

std::string to_json(const FoveationConfig& config)
{
    std::string text = "{\n";
    text += "  \"levels\": " + std::to_string(config.levels()) + ",\n";
    text += "  \"downsample\": \"" + std::string(to_string(config.downsample)) + "\",\n";
    text += "  \"structures\": [";
    for (std::size_t i = 0; i < config.structures.size(); ++i) {
        const FoveatedStructure& structure = config.structures[i];
        text += i ? ",\n    {\n" : "\n    {\n";
        if (!structure.name.empty()) {
            // Invalid UTF-8 in a hand-set name is replaced rather than failing the whole write.
            const std::string name =
                json(structure.name).dump(-1, ' ', false, json::error_handler_t::replace);
            text += "      \"name\": " + name + ",\n";
        }
        // A structure whose m differs from the first one's is written as it is, so that reading
        // the text back reports the mismatch instead of hiding it.
        if (structure.levels != config.levels()) {
            text += "      \"levels\": " + std::to_string(structure.levels) + ",\n";
        }
        text += "      \"outer_min\": " + json_vector(structure.outer_min) + ",\n";
        text += "      \"outer_size\": " + json_vector(structure.outer_size) + ",\n";
        text += "      \"fovea_size\": " + json_vector(structure.fovea_size) + ",\n";
        if (const std::string center = json_fovea_center(structure); !center.empty()) {
            text += "      \"fovea_center\": " + center + ",\n";
        } else {
            // Only for an F too small to survive being added to Δ + S_0/2: say F itself.
            text += "      \"fovea_offset\": " + json_vector(structure.fovea_offset) + ",\n";
        }
        text += "      \"density\": [" + json_number(structure.density_outer) + ", " +
                json_number(structure.density_fovea) + "],\n";
        text += "      \"keypoint_radius\": [" + json_number(structure.keypoint_radius_outer) + ", " +
                json_number(structure.keypoint_radius_fovea) + "]\n";
        text += "    }";
    }
    text += config.structures.empty() ? "]\n}\n" : "\n  ]\n}\n";
    return text;
}

const char* to_string(FoveationMode mode)
{
    switch (mode) {
    case FoveationMode::none: return "none";
    case FoveationMode::single: return "single";
    case FoveationMode::raw: return "raw";
    case FoveationMode::mfpc: return "mfpc";
    }
    return "unknown";
}

const char* to_string(Downsample downsample)
{
    switch (downsample) {
    case Downsample::voxel: return "voxel";
    case Downsample::uniform: return "uniform";
    }
    return "unknown";
}

FoveationMode parse_foveation_mode(std::string_view text, const std::string& where)
{
    for (FoveationMode mode :
         {FoveationMode::none, FoveationMode::single, FoveationMode::raw, FoveationMode::mfpc}) {
        if (text == to_string(mode)) return mode;
    }
    throw Error(where, "unknown foveation mode " + detail::quoted(text) + " (expected none, single, raw or mfpc)");
}

Downsample parse_downsample(std::string_view text, const std::string& where)
{
    for (Downsample downsample : {Downsample::voxel, Downsample::uniform}) {
        if (text == to_string(downsample)) return downsample;
    }
    throw Error(where, "unknown downsample " + detail::quoted(text) + " (expected voxel or uniform)");
}

}  // namespace mfpc
