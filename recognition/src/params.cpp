#include "mfpc/recognition/params.hpp"

#include <cmath>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/json_check.hpp"
#include "mfpc/core/detail/text_file.hpp"

namespace mfpc {
namespace {

using nlohmann::json;

// Reads one JSON object's keys into fields, rejecting unknown keys and wrong types; every error
// names "source: path.key".
class ObjectReader {
public:
    ObjectReader(const json& object, std::string path, const std::string& source)
        : object_(object), path_(std::move(path)), source_(source)
    {
        if (!object_.is_object()) fail(path_.empty() ? "(document)" : path_, "must be a JSON object");
    }
    ~ObjectReader() noexcept(false)
    {
        if (std::uncaught_exceptions()) return;
        for (const auto& [key, value] : object_.items())
            if (!known_.count(key)) fail(name(key), "unknown key (see the README, \"Recognition parameters\")");
    }
    void number(const char* key, float& out)
    {
        if (const json* v = find(key)) {
            if (!v->is_number()) fail(name(key), "must be a number");
            const double value = v->get<double>();
            if (!std::isfinite(value) || std::abs(value) > 3.0e38) fail(name(key), "must be a finite number");
            out = float(value);
        }
    }
    void integer(const char* key, int& out)
    {
        if (const json* v = find(key)) {
            if (!v->is_number_integer()) fail(name(key), "must be an integer");
            const auto value = v->get<std::int64_t>();
            if (value < -1000000000 || value > 1000000000) fail(name(key), "is out of range");
            out = int(value);
        }
    }
    void boolean(const char* key, bool& out)
    {
        if (const json* v = find(key)) {
            if (!v->is_boolean()) fail(name(key), "must be true or false");
            out = v->get<bool>();
        }
    }
    template <class Enum>
    void choice(const char* key, Enum& out, std::initializer_list<std::pair<const char*, Enum>> choices)
    {
        if (const json* v = find(key)) {
            std::string options;
            for (const auto& [text, value] : choices) {
                if (v->is_string() && v->get<std::string>() == text) {
                    out = value;
                    return;
                }
                options += options.empty() ? text : std::string("|") + text;
            }
            fail(name(key), "must be one of " + options);
        }
    }
    const json* object(const char* key) { return find(key); }
    std::string name(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
    [[noreturn]] void fail(const std::string& key, const std::string& reason) const
    {
        throw Error(source_ + ": " + key, reason);
    }

private:
    const json* find(const char* key)
    {
        known_.insert(key);
        const auto it = object_.find(key);
        return it == object_.end() ? nullptr : &*it;
    }
    const json& object_;
    std::string path_;
    const std::string& source_;
    std::set<std::string> known_;
};

void read_features(const json& object, const std::string& path, const std::string& source, FeatureParams& out)
{
    ObjectReader r(object, path, source);
    r.number("resolution", out.resolution);
    r.integer("normal_k", out.normal_k);
    r.number("keypoint_radius", out.keypoint_radius);
    r.number("lrf_radius", out.lrf_radius);
    r.number("shot_radius", out.shot_radius);
}

double clean(float value) { return shortest_double(value); }

json features_json(const FeatureParams& p)
{
    return {{"resolution", clean(p.resolution)},
            {"normal_k", p.normal_k},
            {"keypoint_radius", clean(p.keypoint_radius)},
            {"lrf_radius", clean(p.lrf_radius)},
            {"shot_radius", clean(p.shot_radius)}};
}

void check_positive(float value, const std::string& source, const std::string& key)
{
    if (!(value > 0.0f) || !std::isfinite(value))
        throw Error(source + ": " + key, "must be a positive number, got " + format_number(value));
}

void check_fraction(float value, const std::string& source, const std::string& key)
{
    if (!(value >= 0.0f && value <= 1.0f)) throw Error(source + ": " + key, "must lie in [0, 1], got " + format_number(value));
}

}  // namespace

const char* to_string(NormalsFrom value) { return value == NormalsFrom::full ? "full" : "foveated"; }
const char* to_string(MatchDirection value)
{
    return value == MatchDirection::scene_to_model ? "scene_to_model" : "model_to_scene";
}
const char* to_string(MatchSearch value)
{
    return value == MatchSearch::scan ? "scan" : value == MatchSearch::kdtree ? "kdtree" : "randomized";
}
const char* to_string(Grouping value) { return value == Grouping::hough ? "hough" : "gc"; }

void check_recognition_params(const RecognitionParams& p, const std::string& source)
{
    for (const auto& [side, f] : {std::pair{"scene", &p.scene}, std::pair{"model", &p.model}}) {
        const std::string prefix = std::string(side) + ".";
        if (!(f->resolution >= 0.0f && f->resolution <= 0.1f))
            throw Error(source + ": " + prefix + "resolution",
                        "must lie in [0, 0.1] metres (0: as sampled), got " + format_number(f->resolution));
        if (f->normal_k < 3 || f->normal_k > 1000)
            throw Error(source + ": " + prefix + "normal_k", "must lie in 3..1000, got " + std::to_string(f->normal_k));
        check_positive(f->keypoint_radius, source, prefix + "keypoint_radius");
        check_positive(f->lrf_radius, source, prefix + "lrf_radius");
        check_positive(f->shot_radius, source, prefix + "shot_radius");
    }
    check_positive(p.match.threshold, source, "match_threshold");
    if (p.match.k < 1 || p.match.k > 100) throw Error(source + ": match_k", "must lie in 1..100");
    if (p.match.trees < 1 || p.match.trees > 64) throw Error(source + ": match_trees", "must lie in 1..64");
    if (p.match.checks < 1) throw Error(source + ": match_checks", "must be at least 1");
    check_positive(p.grouping.hough_bin, source, "hough_bin");
    check_positive(p.grouping.hough_threshold, source, "hough_threshold");
    check_positive(p.grouping.gc_size, source, "gc_size");
    if (p.grouping.gc_threshold < 3) throw Error(source + ": gc_threshold", "must be at least 3");
    check_positive(p.grouping.ransac_distance, source, "ransac_distance");
    // Each iteration is a pass over the cluster's correspondences, for every cluster, so a huge count
    // (1000000000) looks like a hang. 100000 is 200 times the default and more than RANSAC needs:
    // with 5% inliers, 100000 draws all miss an all-inlier sample with probability below 1e-5.
    if (p.grouping.ransac_iterations < 1 || p.grouping.ransac_iterations > 100000)
        throw Error(source + ": ransac_iterations",
                    "must lie in 1..100000, got " + std::to_string(p.grouping.ransac_iterations));
    if (p.grouping.ransac_modes < 1 || p.grouping.ransac_modes > 16)
        throw Error(source + ": ransac_modes", "must lie in 1..16, got " + std::to_string(p.grouping.ransac_modes));
    check_fraction(p.grouping.mode_inlier_ratio, source, "mode_inlier_ratio");
    if (!(p.grouping.mode_min_angle >= 0.0f && p.grouping.mode_min_angle <= 180.0f))
        throw Error(source + ": mode_min_angle",
                    "must lie in [0, 180] degrees, got " + format_number(p.grouping.mode_min_angle));
    if (p.refine.iterations < 0 || p.refine.iterations > 10000)
        throw Error(source + ": refine.iterations", "must lie in 0..10000");
    check_positive(p.refine.max_distance, source, "refine.max_distance");
    if (!(p.refine.model_voxel >= 0.0f)) throw Error(source + ": refine.model_voxel", "must be 0 or positive");
    check_positive(p.verify.inlier_distance, source, "verify.inlier_distance");
    check_fraction(p.verify.min_inlier_fraction, source, "verify.min_inlier_fraction");
    check_fraction(p.verify.min_coverage, source, "verify.min_coverage");
    check_fraction(p.verify.min_facing_cos, source, "verify.min_facing_cos");
    check_fraction(p.verify.prefilter_coverage, source, "verify.prefilter_coverage");
    check_fraction(p.verify.min_thickness_ratio, source, "verify.min_thickness_ratio");
    check_positive(p.verify.flat_side, source, "verify.flat_side");
    check_fraction(p.verify.max_continuation, source, "verify.max_continuation");
    check_positive(p.verify.rim_distance, source, "verify.rim_distance");
    if (p.verify.min_rim_probes < 0 || p.verify.min_rim_probes > 1000000)
        throw Error(source + ": verify.min_rim_probes",
                    "must lie in 0..1000000, got " + std::to_string(p.verify.min_rim_probes));
    check_fraction(p.verify.settled_fitness, source, "verify.settled_fitness");
    check_fraction(p.verify.turn_overlap, source, "verify.turn_overlap");
    check_positive(p.verify.free_space_margin, source, "verify.free_space_margin");
    check_fraction(p.verify.max_free_space_fraction, source, "verify.max_free_space_fraction");
    check_positive(p.verify.merge_distance, source, "verify.merge_distance");
    check_fraction(p.verify.merge_overlap, source, "verify.merge_overlap");
}

RecognitionParams parse_recognition_params(std::string_view json_text, const std::string& source)
{
    // Duplicate keys, deep nesting and syntax errors, named the way every JSON reader names them
    // (nlohmann alone keeps the last of two equal keys); the text is then known to parse.
    check_json_text(json_text, source);
    const json root = json::parse(json_text);
    RecognitionParams p;
    {
        ObjectReader r(root, "", source);
        // Files written before the key was renamed get told what to write instead.
        if (root.contains("match_exact"))
            throw Error(source + ": match_exact", "renamed match_search: \"scan\" or \"kdtree\" for exact (true), "
                                                  "\"randomized\" for approximate (false)");
        if (const json* scene = r.object("scene")) read_features(*scene, "scene", source, p.scene);
        if (const json* model = r.object("model")) read_features(*model, "model", source, p.model);
        r.choice("normals_from", p.normals_from, {{"full", NormalsFrom::full}, {"foveated", NormalsFrom::foveated}});
        r.number("match_threshold", p.match.threshold);
        r.choice("match_direction", p.match.direction,
                 {{"model_to_scene", MatchDirection::model_to_scene}, {"scene_to_model", MatchDirection::scene_to_model}});
        r.integer("match_k", p.match.k);
        r.choice("match_search", p.match.search,
                 {{"scan", MatchSearch::scan}, {"kdtree", MatchSearch::kdtree}, {"randomized", MatchSearch::randomized}});
        r.integer("match_trees", p.match.trees);
        r.integer("match_checks", p.match.checks);
        r.choice("grouping", p.grouping.method, {{"hough", Grouping::hough}, {"gc", Grouping::gc}});
        r.number("hough_bin", p.grouping.hough_bin);
        r.number("hough_threshold", p.grouping.hough_threshold);
        r.number("gc_size", p.grouping.gc_size);
        r.integer("gc_threshold", p.grouping.gc_threshold);
        r.number("ransac_distance", p.grouping.ransac_distance);
        r.integer("ransac_iterations", p.grouping.ransac_iterations);
        r.integer("ransac_modes", p.grouping.ransac_modes);
        r.number("mode_inlier_ratio", p.grouping.mode_inlier_ratio);
        r.number("mode_min_angle", p.grouping.mode_min_angle);
        if (const json* refine = r.object("refine")) {
            ObjectReader q(*refine, "refine", source);
            q.boolean("enabled", p.refine.enabled);
            q.integer("iterations", p.refine.iterations);
            q.number("max_distance", p.refine.max_distance);
            q.number("model_voxel", p.refine.model_voxel);
        }
        if (const json* verify = r.object("verify")) {
            ObjectReader q(*verify, "verify", source);
            q.boolean("enabled", p.verify.enabled);
            q.number("inlier_distance", p.verify.inlier_distance);
            q.number("min_inlier_fraction", p.verify.min_inlier_fraction);
            q.number("min_coverage", p.verify.min_coverage);
            q.number("min_facing_cos", p.verify.min_facing_cos);
            q.number("prefilter_coverage", p.verify.prefilter_coverage);
            q.number("min_thickness_ratio", p.verify.min_thickness_ratio);
            q.number("flat_side", p.verify.flat_side);
            q.number("max_continuation", p.verify.max_continuation);
            q.number("rim_distance", p.verify.rim_distance);
            q.integer("min_rim_probes", p.verify.min_rim_probes);
            q.number("settled_fitness", p.verify.settled_fitness);
            q.boolean("try_turns", p.verify.try_turns);
            q.number("turn_overlap", p.verify.turn_overlap);
            q.number("free_space_margin", p.verify.free_space_margin);
            q.number("max_free_space_fraction", p.verify.max_free_space_fraction);
            q.boolean("merge", p.verify.merge);
            q.number("merge_distance", p.verify.merge_distance);
            q.number("merge_overlap", p.verify.merge_overlap);
        }
    }
    check_recognition_params(p, source);
    return p;
}

RecognitionParams read_recognition_params(const std::filesystem::path& path)
{
    return parse_recognition_params(read_text_file(path), path.string());
}

std::string to_json(const FeatureParams& p) { return features_json(p).dump(2) + "\n"; }

std::string to_json(const RecognitionParams& p)
{
    const json root = {
        {"scene", features_json(p.scene)},
        {"model", features_json(p.model)},
        {"normals_from", to_string(p.normals_from)},
        {"match_threshold", clean(p.match.threshold)},
        {"match_direction", to_string(p.match.direction)},
        {"match_k", p.match.k},
        {"match_search", to_string(p.match.search)},
        {"match_trees", p.match.trees},
        {"match_checks", p.match.checks},
        {"grouping", to_string(p.grouping.method)},
        {"hough_bin", clean(p.grouping.hough_bin)},
        {"hough_threshold", clean(p.grouping.hough_threshold)},
        {"gc_size", clean(p.grouping.gc_size)},
        {"gc_threshold", p.grouping.gc_threshold},
        {"ransac_distance", clean(p.grouping.ransac_distance)},
        {"ransac_iterations", p.grouping.ransac_iterations},
        {"ransac_modes", p.grouping.ransac_modes},
        {"mode_inlier_ratio", clean(p.grouping.mode_inlier_ratio)},
        {"mode_min_angle", clean(p.grouping.mode_min_angle)},
        {"refine",
         {{"enabled", p.refine.enabled},
          {"iterations", p.refine.iterations},
          {"max_distance", clean(p.refine.max_distance)},
          {"model_voxel", clean(p.refine.model_voxel)}}},
        {"verify",
         {{"enabled", p.verify.enabled},
          {"inlier_distance", clean(p.verify.inlier_distance)},
          {"min_inlier_fraction", clean(p.verify.min_inlier_fraction)},
          {"min_coverage", clean(p.verify.min_coverage)},
          {"min_facing_cos", clean(p.verify.min_facing_cos)},
          {"prefilter_coverage", clean(p.verify.prefilter_coverage)},
          {"min_thickness_ratio", clean(p.verify.min_thickness_ratio)},
          {"flat_side", clean(p.verify.flat_side)},
          {"max_continuation", clean(p.verify.max_continuation)},
          {"rim_distance", clean(p.verify.rim_distance)},
          {"min_rim_probes", p.verify.min_rim_probes},
          {"settled_fitness", clean(p.verify.settled_fitness)},
          {"try_turns", p.verify.try_turns},
          {"turn_overlap", clean(p.verify.turn_overlap)},
          {"free_space_margin", clean(p.verify.free_space_margin)},
          {"max_free_space_fraction", clean(p.verify.max_free_space_fraction)},
          {"merge", p.verify.merge},
          {"merge_distance", clean(p.verify.merge_distance)},
          {"merge_overlap", clean(p.verify.merge_overlap)}}},
    };
    return root.dump(2) + "\n";
}

}  // namespace mfpc
