#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/detail/json_check.hpp"
#include "mfpc/core/pose.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

// A config as text, built from key/value pairs so that each bad-config case changes one thing.
using Fields = std::vector<std::pair<std::string, std::string>>;

Fields base_structure()
{
    return {{"outer_min", "[0, 0, 0]"},    {"outer_size", "[4, 4, 4]"},
            {"fovea_size", "[2, 2, 2]"},   {"fovea_offset", "[0.5, -0.5, 0]"},
            {"density", "[0.02, 0.005]"}, {"keypoint_radius", "[0.03, 0.01]"}};
}

// Replaces (or adds) `key`; an empty value removes it.
Fields with(Fields fields, const std::string& key, const std::string& value)
{
    bool found = false;
    for (auto it = fields.begin(); it != fields.end();) {
        if (it->first == key) {
            found = true;
            if (value.empty()) {
                it = fields.erase(it);
                continue;
            }
            it->second = value;
        }
        ++it;
    }
    if (!found && !value.empty()) fields.emplace_back(key, value);
    return fields;
}

std::string object(const Fields& fields)
{
    std::string text = "{";
    for (std::size_t i = 0; i < fields.size(); ++i) {
        text += (i ? ", \"" : "\"") + fields[i].first + "\": " + fields[i].second;
    }
    return text + "}";
}

std::string structures(const std::vector<Fields>& list)
{
    std::string text = "[";
    for (std::size_t i = 0; i < list.size(); ++i) text += (i ? ", " : "") + object(list[i]);
    return text + "]";
}

Fields base_config(const std::vector<Fields>& list = {base_structure()})
{
    return {{"levels", "3"}, {"structures", structures(list)}};
}

std::string config_text(const Fields& top = base_config()) { return object(top); }

// The what() of the error the text raises, or "" (and a failure) when it parses.
std::string error_of(const std::string& text, FoveaPolicy policy = FoveaPolicy::clamp)
{
    try {
        parse_foveation_config(text, "cfg.json", policy);
    } catch (const Error& error) {
        return error.what();
    }
    ADD_FAILURE() << "parsed without an error: " << text;
    return {};
}

void expect_error(const std::string& text, const std::string& where, const std::string& reason = {})
{
    SCOPED_TRACE(text);
    const std::string what = error_of(text);
    EXPECT_EQ(what.rfind("cfg.json: " + where, 0), 0u) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    if (!reason.empty()) {
        EXPECT_NE(what.find(reason), std::string::npos) << what;
    }
}

void expect_same(const FoveatedStructure& a, const FoveatedStructure& b)
{
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.levels, b.levels);
    EXPECT_EQ(a.outer_min, b.outer_min);
    EXPECT_EQ(a.outer_size, b.outer_size);
    EXPECT_EQ(a.fovea_size, b.fovea_size);
    EXPECT_EQ(a.fovea_offset, b.fovea_offset);
    EXPECT_EQ(a.density_outer, b.density_outer);
    EXPECT_EQ(a.density_fovea, b.density_fovea);
    EXPECT_EQ(a.keypoint_radius_outer, b.keypoint_radius_outer);
    EXPECT_EQ(a.keypoint_radius_fovea, b.keypoint_radius_fovea);
}

void expect_same(const FoveationConfig& a, const FoveationConfig& b)
{
    EXPECT_EQ(a.levels(), b.levels());
    EXPECT_EQ(a.downsample, b.downsample);
    ASSERT_EQ(a.structures.size(), b.structures.size());
    for (std::size_t i = 0; i < a.structures.size(); ++i) {
        SCOPED_TRACE("structure " + std::to_string(i));
        expect_same(a.structures[i], b.structures[i]);
    }
}

TEST(FoveationConfig, ParsesAMinimalConfig)
{
    std::vector<std::string> warnings;
    const FoveationConfig config =
        parse_foveation_config(config_text(), "cfg.json", FoveaPolicy::clamp, &warnings);
    EXPECT_TRUE(warnings.empty());
    EXPECT_EQ(config.levels(), 3);
    EXPECT_EQ(config.downsample, Downsample::voxel);
    ASSERT_EQ(config.structures.size(), 1u);
    const FoveatedStructure& s = config.structures[0];
    EXPECT_EQ(s.levels, 3);
    EXPECT_EQ(s.outer_min, Eigen::Vector3f(0, 0, 0));
    EXPECT_EQ(s.outer_size, Eigen::Vector3f(4, 4, 4));
    EXPECT_EQ(s.fovea_size, Eigen::Vector3f(2, 2, 2));
    EXPECT_EQ(s.fovea_offset, Eigen::Vector3f(0.5f, -0.5f, 0));
    EXPECT_EQ(s.density_outer, 0.02f);
    EXPECT_EQ(s.density_fovea, 0.005f);
    EXPECT_EQ(s.keypoint_radius_outer, 0.03f);
    EXPECT_EQ(s.keypoint_radius_fovea, 0.01f);
    EXPECT_TRUE(s.name.empty());
}

TEST(FoveationConfig, ParsesEveryOptionalKey)
{
    const Fields first = with(with(with(base_structure(), "name", "\"carton \\\"A\\\"\""), "levels", "2"),
                              "fovea_offset", "");
    const Fields second = with(with(base_structure(), "density", "[0, 0]"), "outer_min", "[-1.5, 2, 1e-3]");
    const std::string text = config_text(
        {{"levels", "2"},
         {"downsample", "\"uniform\""},
         {"structures", structures({with(first, "fovea_center", "[3, 1, 2]"), second})}});
    const FoveationConfig config = parse_foveation_config(text, "cfg.json");
    EXPECT_EQ(config.levels(), 2);
    EXPECT_EQ(config.downsample, Downsample::uniform);
    ASSERT_EQ(config.structures.size(), 2u);
    EXPECT_EQ(config.structures[0].name, "carton \"A\"");
    // F = c - Δ - S_0/2.
    EXPECT_EQ(config.structures[0].fovea_offset, Eigen::Vector3f(1, -1, 0));
    EXPECT_EQ(config.structures[0].fovea_center(), Eigen::Vector3f(3, 1, 2));
    EXPECT_EQ(config.structures[1].levels, 2);
    EXPECT_EQ(config.structures[1].outer_min, Eigen::Vector3f(-1.5f, 2, 1e-3f));
    EXPECT_EQ(config.structures[1].density(1), 0.0f);
}

TEST(FoveationConfig, ClampsAFoveaOutsideTheOuterBoxWithAWarning)
{
    // Limit (S_0 - S_m)/2 = 1; F = (0.5, -1.75, 3) is out on y and z.
    const std::string text =
        config_text(base_config({base_structure(), with(base_structure(), "fovea_offset", "[0.5, -1.75, 3]")}));
    std::vector<std::string> warnings;
    const FoveationConfig config =
        parse_foveation_config(text, "cfg.json", FoveaPolicy::clamp, &warnings);
    EXPECT_EQ(config.structures[1].fovea_offset, Eigen::Vector3f(0.5f, -1, 1));
    ASSERT_EQ(warnings.size(), 2u);
    EXPECT_EQ(warnings[0],
              "cfg.json: structures[1].fovea_offset: fovea outside the outer box on y: offset -1.75 "
              "beyond ±1, clamped to -1");
    EXPECT_EQ(warnings[1],
              "cfg.json: structures[1].fovea_offset: fovea outside the outer box on z: offset 3 "
              "beyond ±1, clamped to 1");
    // The clamped fovea touches the outer box's faces and the boxes stay nested.
    const FoveatedStructure& s = config.structures[1];
    EXPECT_EQ(s.level_box(3).min.y(), 0.0f);
    EXPECT_EQ(s.level_box(3).max.z(), 4.0f);

    // No warnings vector: still clamped, nothing reported.
    const FoveationConfig quiet = parse_foveation_config(text, "cfg.json");
    EXPECT_EQ(quiet.structures[1].fovea_offset, Eigen::Vector3f(0.5f, -1, 1));
}

TEST(FoveationConfig, ClampWarningForAFoveaCentreNamesTheCentre)
{
    const std::string text = config_text(
        base_config({with(with(base_structure(), "fovea_offset", ""), "fovea_center", "[2, 2, 5.5]")}));
    std::vector<std::string> warnings;
    const FoveationConfig config =
        parse_foveation_config(text, "cfg.json", FoveaPolicy::clamp, &warnings);
    EXPECT_EQ(config.structures[0].fovea_center(), Eigen::Vector3f(2, 2, 3));
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_EQ(warnings[0],
              "cfg.json: structures[0].fovea_center: fovea outside the outer box on z: offset 3.5 "
              "beyond ±1, clamped to 1 (centre 3)");
}

TEST(FoveationConfig, StrictPolicyRejectsAFoveaOutsideTheOuterBox)
{
    const std::string text =
        config_text(base_config({with(base_structure(), "fovea_offset", "[0, 1.25, 0]")}));
    const std::string what = error_of(text, FoveaPolicy::strict);
    EXPECT_EQ(what, "cfg.json: structures[0].fovea_offset: fovea outside the outer box on y: offset "
                    "1.25 beyond ±1");
    // A fovea exactly at the limit is inside, under either policy.
    const std::string at_limit =
        config_text(base_config({with(base_structure(), "fovea_offset", "[1, -1, 1]")}));
    std::vector<std::string> warnings;
    EXPECT_NO_THROW(parse_foveation_config(at_limit, "cfg.json", FoveaPolicy::strict, &warnings));
    EXPECT_NO_THROW(parse_foveation_config(at_limit, "cfg.json", FoveaPolicy::clamp, &warnings));
    EXPECT_TRUE(warnings.empty());
}

// A fovea centre written flush with the outer box's face lands a float rounding or two beyond the
// limit: on the face, so accepted under --strict and not warned about.
TEST(FoveationConfig, AFoveaFlushWithItsOuterBoxIsInside)
{
    for (const char* center : {"[0.65, 0.45, 1.5]", "[0.25, 0.25, 0.8]"}) {
        const std::string text =
            "{\"levels\": 3, \"structures\": [{\"outer_min\": [0.1, 0.2, 0.7], \"outer_size\": [0.7, 0.3, 0.9], "
            "\"fovea_size\": [0.3, 0.1, 0.2], \"density\": [0.02, 0.005], \"keypoint_radius\": [0.03, 0.01], "
            "\"fovea_center\": " +
            std::string(center) + "}]}";
        std::vector<std::string> warnings;
        EXPECT_NO_THROW(parse_foveation_config(text, "cfg.json", FoveaPolicy::strict, &warnings)) << center;
        parse_foveation_config(text, "cfg.json", FoveaPolicy::clamp, &warnings);
        EXPECT_TRUE(warnings.empty()) << center << ": " << (warnings.empty() ? "" : warnings[0]);
    }
    // A fovea as large as its outer box: the only offset is 0.
    const std::string same = "{\"levels\": 2, \"structures\": [{\"outer_min\": [0.1, 0.2, 0.7], \"outer_size\": "
                             "[0.3, 0.3, 0.3], \"fovea_size\": [0.3, 0.3, 0.3], \"density\": [0.02, 0.005], "
                             "\"keypoint_radius\": [0.03, 0.01], "
                             "\"fovea_center\": [0.25, 0.35, 0.85]}]}";
    EXPECT_NO_THROW(parse_foveation_config(same, "cfg.json", FoveaPolicy::strict));
}

// The foveation kernel's bound on levels is the reader's.
TEST(FoveationConfig, LevelsAreBoundedAsTheKernelBoundsThem)
{
    EXPECT_EQ(error_of("{\"levels\": 127, \"structures\": []}"), "cfg.json: levels: at most 126 levels are supported");
}

TEST(FoveationConfig, RejectsBadJson)
{
    const std::string what = error_of("{\"levels\": 3,\n \"structures\": [}");
    EXPECT_EQ(what.rfind("cfg.json: invalid JSON: ", 0), 0u) << what;
    EXPECT_NE(what.find("line 2"), std::string::npos) << what;
    EXPECT_EQ(error_of("").rfind("cfg.json: invalid JSON", 0), 0u);
    EXPECT_EQ(error_of("[1, 2]"), "cfg.json: a foveation config must be a JSON object");
    EXPECT_EQ(error_of("{\"levels\": 3, \"structures\": []} trailing").rfind("cfg.json: invalid JSON", 0),
              0u);
}

TEST(FoveationConfig, RejectsBadTopLevelKeys)
{
    expect_error(config_text(with(base_config(), "colour", "1")), "colour", "unknown key");
    expect_error(config_text(with(base_config(), "levels", "")), "levels", "missing");
    expect_error(config_text(with(base_config(), "levels", "0")), "levels", "at least 1");
    expect_error(config_text(with(base_config(), "levels", "-2")), "levels", "at least 1");
    expect_error(config_text(with(base_config(), "levels", "2.5")), "levels", "integer");
    expect_error(config_text(with(base_config(), "levels", "\"3\"")), "levels", "integer");
    expect_error(config_text(with(base_config(), "levels", "40000")), "levels", "at most");
    expect_error(config_text(with(base_config(), "levels", "18446744073709551615")), "levels", "at most");
    expect_error(config_text(with(base_config(), "downsample", "\"cubic\"")), "downsample", "cubic");
    expect_error(config_text(with(base_config(), "downsample", "1")), "downsample", "string");
    expect_error(config_text(with(base_config(), "structures", "")), "structures", "missing");
    expect_error(config_text(with(base_config(), "structures", "{}")), "structures", "array");
    expect_error(config_text(with(base_config(), "structures", "[]")), "structures", "at least one");
    expect_error(config_text(with(base_config(), "structures", "[3]")), "structures[0]", "object");
}

TEST(FoveationConfig, RejectsBadStructureKeys)
{
    const auto bad = [](const std::string& key, const std::string& value) {
        // The bad structure is the second one, so the index in the path is checked too.
        return config_text(base_config({base_structure(), with(base_structure(), key, value)}));
    };
    const std::string s = "structures[1]";
    expect_error(bad("fovea_centre", "[1, 1, 1]"), s + ".fovea_centre", "unknown key");
    expect_error(bad("outer_min", ""), s + ".outer_min", "missing");
    expect_error(bad("outer_size", ""), s + ".outer_size", "missing");
    expect_error(bad("fovea_size", ""), s + ".fovea_size", "missing");
    expect_error(bad("density", ""), s + ".density", "missing");
    expect_error(bad("keypoint_radius", ""), s + ".keypoint_radius", "missing");
    expect_error(bad("outer_min", "[0, 0]"), s + ".outer_min", "array of 3 numbers");
    expect_error(bad("outer_min", "[0, 0, 0, 0]"), s + ".outer_min", "array of 3 numbers");
    expect_error(bad("outer_min", "0"), s + ".outer_min", "array of 3 numbers");
    expect_error(bad("outer_min", "[0, \"1\", 0]"), s + ".outer_min[1]", "number");
    expect_error(bad("outer_min", "[0, null, 0]"), s + ".outer_min[1]", "number");
    expect_error(bad("outer_min", "[0, 0, 1e39]"), s + ".outer_min[2]", "finite");
    // Beyond double: nlohmann refuses it while parsing, before any key path is known.
    EXPECT_EQ(error_of(bad("outer_min", "[0, 0, 1e999]")),
              "cfg.json: invalid JSON: number overflow parsing '1e999'");
    expect_error(config_text(base_config({base_structure(),
                                          with(with(base_structure(), "outer_min", "[3.4e38, 0, 0]"),
                                               "outer_size", "[1e38, 4, 4]")})),
                 s + ".outer_size", "float range");
    expect_error(bad("outer_size", "[4, 0, 4]"), s + ".outer_size", "positive");
    expect_error(bad("outer_size", "[4, 4, -4]"), s + ".outer_size", "positive");
    expect_error(bad("fovea_size", "[0, 2, 2]"), s + ".fovea_size", "positive");
    expect_error(bad("fovea_size", "[2, 4.5, 2]"), s + ".fovea_size", "fovea bigger than the outer box");
    expect_error(bad("fovea_center", "[2, 2, 2]"), s, "both fovea_center and fovea_offset");
    expect_error(bad("fovea_offset", ""), s, "needs fovea_center or fovea_offset");
    expect_error(bad("fovea_offset", "[0, 0]"), s + ".fovea_offset", "array of 3 numbers");
    expect_error(bad("density", "[0.02]"), s + ".density", "array of 2 numbers");
    expect_error(bad("density", "[0.02, -0.005]"), s + ".density[1]", "negative");
    expect_error(bad("density", "[-1, 0.005]"), s + ".density[0]", "negative");
    expect_error(bad("keypoint_radius", "[0.03, 0]"), s + ".keypoint_radius[1]", "positive");
    expect_error(bad("keypoint_radius", "[-0.03, 0.01]"), s + ".keypoint_radius[0]", "positive");
    expect_error(bad("keypoint_radius", "[0.03, 0.01, 0.005]"), s + ".keypoint_radius",
                 "array of 2 numbers");
    expect_error(bad("levels", "2"), s + ".levels", "structures with different levels");
    expect_error(bad("levels", "0"), s + ".levels", "at least 1");
    expect_error(bad("name", "7"), s + ".name", "string");
}

TEST(FoveationConfig, RejectsDuplicateKeys)
{
    expect_error("{\"levels\": 3, \"levels\": 3, \"structures\": []}", "levels", "duplicate key");
    Fields twice = base_structure();
    twice.emplace_back("density", "[0.01, 0.001]");
    expect_error(config_text(base_config({base_structure(), base_structure(), twice})),
                 "structures[2].density", "duplicate key");
}

// `depth` arrays, one inside the other: "[[[...]]]".
std::string nested_arrays(int depth)
{
    return std::string(std::size_t(depth), '[') + std::string(std::size_t(depth), ']');
}

// The what() of check_json_text on `text`, or "" when the text passes.
std::string check_error(const std::string& text)
{
    try {
        check_json_text(text, "in.json");
    } catch (const Error& error) {
        return error.what();
    }
    return {};
}

// check_json_text is what every JSON reader runs first (the foveation config reader included), so
// its rules are tested here once and each reader's tests check only that it calls it.
TEST(JsonCheck, RejectsDuplicateKeysByTheirPath)
{
    EXPECT_EQ(check_error(R"({"a": 1, "b": {"c": [1, {"d": 1, "d": 2}]}})"), "in.json: b.c[1].d: duplicate key");
    EXPECT_EQ(check_error(R"({"a": 1, "a": 1})"), "in.json: a: duplicate key");
    // The same key in two different objects is fine.
    EXPECT_EQ(check_error(R"({"a": {"k": 1}, "b": {"k": 1}, "c": [{"k": 1}, {"k": 2}]})"), "");
}

TEST(JsonCheck, LimitsTheNestingDepth)
{
    EXPECT_EQ(check_error(nested_arrays(20)), "");
    EXPECT_EQ(check_error(nested_arrays(json_depth_limit)), "");
    EXPECT_EQ(check_error(nested_arrays(json_depth_limit + 1)), "in.json: invalid JSON: nested deeper than 64 levels");
    EXPECT_EQ(check_error(nested_arrays(100)), "in.json: invalid JSON: nested deeper than 64 levels");
    // Objects count as levels too; the limit stops the parser before the end of the text, so an
    // unclosed document that deep is refused for its depth.
    std::string objects;
    for (int i = 0; i < 100; ++i) objects += "{\"k\": ";
    EXPECT_EQ(check_error(objects), "in.json: invalid JSON: nested deeper than 64 levels");
    // The foveation config reader applies it before reading any key.
    EXPECT_EQ(error_of(nested_arrays(100)), "cfg.json: invalid JSON: nested deeper than 64 levels");
}

TEST(JsonCheck, SyntaxErrorsWithoutTheParserPrefix)
{
    const std::string what = check_error("{\"a\": [1,\n 2,}");
    EXPECT_EQ(what.rfind("in.json: invalid JSON: parse error at line 2", 0), 0u) << what;
    EXPECT_EQ(what.find("json.exception"), std::string::npos) << what;
    EXPECT_EQ(check_error("[1e999]"), "in.json: invalid JSON: number overflow parsing '1e999'");
    EXPECT_EQ(check_error("").rfind("in.json: invalid JSON: ", 0), 0u);
    EXPECT_EQ(check_error(R"({"a": [1, 2, {"b": null}], "c": "text"})"), "");
}

// User text (keys, values) reaches messages quoted, with control characters shown as '?', so a
// key holding a newline cannot split the one line the command line prints.
TEST(FoveationConfig, UserTextInMessagesStaysOnOneLine)
{
    // JSON's "\n" escape: the key itself holds a newline.
    expect_error(config_text(with(base_config(), "a\\nb", "1")), "'a?b'", "unknown key");
    EXPECT_EQ(error_of(config_text(with(base_config(), "a\\nb", "1"))), "cfg.json: 'a?b': unknown key");
    const auto bad = [](const std::string& key, const std::string& value) {
        return config_text(base_config({with(base_structure(), key, value)}));
    };
    expect_error(bad("x\\u0007y", "1"), "structures[0].'x?y'", "unknown key");
    // A key holding '.' or ": " is quoted, so it cannot pose as a path.
    expect_error(bad("outer_min.x", "1"), "structures[0].'outer_min.x'", "unknown key");
    expect_error(bad(std::string(100, 'k'), "1"), "structures[0].'" + std::string(60, 'k') + "...'", "unknown key");
    expect_error("{\"a\\nb\": {\"c\\rd\": 1, \"c\\rd\": 2}}", "'a?b'.'c?d'", "duplicate key");
    expect_error(config_text(with(base_config(), "downsample", "\"vox\\nel\"")), "downsample",
                 "unknown downsample 'vox?el'");
    try {
        parse_foveation_mode("mf\npc", "--mode");
        FAIL() << "an unknown mode was accepted";
    } catch (const Error& error) {
        EXPECT_EQ(std::string(error.what()), "--mode: unknown foveation mode 'mf?pc' (expected none, single, raw or mfpc)");
    }
}

// 1e300 is a double but no float: each numeric key rejects it by name (a plain cast to float
// would be undefined behaviour, which the sanitizer build would report).
TEST(FoveationConfig, RejectsNumbersBeyondFloatInEveryKey)
{
    const auto bad = [](const std::string& key, const std::string& value) {
        return config_text(base_config({with(base_structure(), key, value)}));
    };
    const std::string s = "structures[0]";
    for (const std::string huge : {"1e300", "-1e300", "3.4028236e38"}) {
        SCOPED_TRACE(huge);
        expect_error(bad("outer_min", "[0, " + huge + ", 0]"), s + ".outer_min[1]", "finite number in float range");
        expect_error(bad("outer_size", "[" + huge + ", 4, 4]"), s + ".outer_size[0]", "float range");
        expect_error(bad("fovea_size", "[2, 2, " + huge + "]"), s + ".fovea_size[2]", "float range");
        expect_error(bad("fovea_offset", "[" + huge + ", 0, 0]"), s + ".fovea_offset[0]", "float range");
        const Fields centred = with(with(base_structure(), "fovea_offset", ""), "fovea_center", "[0, " + huge + ", 0]");
        expect_error(config_text(base_config({centred})), s + ".fovea_center[1]", "float range");
        expect_error(bad("density", "[0.02, " + huge + "]"), s + ".density[1]", "float range");
        expect_error(bad("keypoint_radius", "[" + huge + ", 0.01]"), s + ".keypoint_radius[0]", "float range");
        expect_error(config_text(with(base_config(), "levels", huge)), "levels", "integer");
        expect_error(bad("levels", huge), s + ".levels", "integer");
    }
    expect_error(config_text(with(base_config(), "levels", "1e999")), "invalid JSON", "number overflow");
}

// The centre and the outer box are each in float range, but F = (c - Δ) - S_0/2 is not: F is
// infinite, the fovea lies outside, and it is clamped (or refused) like any other far fovea.
TEST(FoveationConfig, FoveaCentreFarBeyondTheBoxIsOutside)
{
    const Fields structure = with(with(with(base_structure(), "outer_min", "[-3e38, 0, 0]"), "fovea_offset", ""),
                                  "fovea_center", "[3e38, 2, 2]");
    const std::string text = config_text(base_config({structure}));
    EXPECT_NE(error_of(text, FoveaPolicy::strict).find("fovea outside the outer box on x"), std::string::npos);
    std::vector<std::string> warnings;
    const FoveationConfig config = parse_foveation_config(text, "cfg.json", FoveaPolicy::clamp, &warnings);
    EXPECT_EQ(config.structures[0].fovea_offset.x(), config.structures[0].fovea_offset_limit().x());
    EXPECT_EQ(warnings.size(), 1u);
}

// "3.4028235e38", the shortest text of the largest float, is a little above it as a double and
// rounds down to it; one step further rounds to infinity and is refused (above).
TEST(FoveationConfig, ReadsTheLargestFloat)
{
    const Fields structure = with(base_structure(), "density", "[3.4028235e38, 0.005]");
    const FoveationConfig config = parse_foveation_config(config_text(base_config({structure})), "cfg.json");
    EXPECT_EQ(config.structures[0].density_outer, std::numeric_limits<float>::max());
    EXPECT_EQ(parse_foveation_config(to_json(config), "back").structures[0].density_outer,
              std::numeric_limits<float>::max());
}

TEST(FoveationConfig, ToJsonRoundTrips)
{
    FoveationConfig config;
    config.downsample = Downsample::uniform;
    FoveatedStructure a;
    a.levels = 4;
    a.name = "carton \"1\"\n\\ é";
    a.outer_min = {-0.288f, -0.463f, 0.5525f};
    a.outer_size = {0.45f, 0.65f, 0.5f};
    a.fovea_size = {0.2f, 0.3f, 0.22f};
    a.set_fovea_center({-0.063f, -0.138f, 0.8025f});
    a.density_outer = 0.02f;
    a.density_fovea = 0.0f;
    a.keypoint_radius_outer = 0.031f;
    a.keypoint_radius_fovea = 1.0f / 3.0f;
    FoveatedStructure b = a;
    b.name.clear();
    b.outer_min = {1e6f, -1e-6f, 0.0f};
    b.outer_size = {1.0f, 1e-3f, 123.456f};
    b.fovea_size = {0.5f, 1e-3f, 7.0f};
    b.fovea_offset = {1e-9f, 0.0f, -b.fovea_offset_limit().z()};  // F far below the resolution of Δ
    config.structures = {a, b};

    const std::string text = to_json(config);
    std::vector<std::string> warnings;
    const FoveationConfig back = parse_foveation_config(text, "round trip", FoveaPolicy::strict, &warnings);
    EXPECT_TRUE(warnings.empty());
    expect_same(config, back);
    EXPECT_NE(text.find("\"fovea_center\""), std::string::npos) << text;
    // Writing again gives the same text.
    EXPECT_EQ(to_json(back), text);
}

TEST(FoveationConfig, ToJsonRoundTripsRandomConfigs)
{
    for (unsigned seed = 1; seed <= 300; ++seed) {
        std::mt19937 random(seed);
        std::uniform_real_distribution<float> coordinate(-5.0f, 5.0f);
        std::uniform_real_distribution<float> size(1e-3f, 3.0f);
        std::uniform_real_distribution<float> fraction(0.0f, 1.0f);
        FoveationConfig config;
        const int levels = 1 + int(seed % 5);
        config.downsample = seed % 2 ? Downsample::voxel : Downsample::uniform;
        for (unsigned j = 0; j <= seed % 3; ++j) {
            FoveatedStructure s;
            s.levels = levels;
            for (int axis = 0; axis < 3; ++axis) {
                s.outer_min[axis] = coordinate(random);
                s.outer_size[axis] = size(random);
                s.fovea_size[axis] = std::max(s.outer_size[axis] * fraction(random), 1e-4f);
            }
            const Eigen::Vector3f limit = s.fovea_offset_limit();
            for (int axis = 0; axis < 3; ++axis) {
                s.fovea_offset[axis] = limit[axis] * (2 * fraction(random) - 1);
            }
            s.density_outer = fraction(random) * 0.05f;
            s.density_fovea = fraction(random) * 0.01f;
            s.keypoint_radius_outer = size(random);
            s.keypoint_radius_fovea = size(random);
            config.structures.push_back(s);
        }
        SCOPED_TRACE("seed " + std::to_string(seed));
        const std::string text = to_json(config);
        expect_same(config, parse_foveation_config(text, "random", FoveaPolicy::strict));
    }
}

TEST(FoveationConfig, ToJsonKeepsAMismatchVisible)
{
    FoveationConfig config;
    config.structures.resize(2);
    config.structures[0].levels = 3;
    config.structures[1].levels = 2;
    const std::string what = error_of(to_json(config));
    EXPECT_NE(what.find("structures[1].levels"), std::string::npos) << what;
}

TEST(FoveationConfig, ReadsAFileAndNamesItInErrors)
{
    test::TempDir dir;
    const auto good = dir.write("good.json", config_text());
    EXPECT_EQ(read_foveation_config(good).structures.size(), 1u);

    const auto bad = dir.write("bad.json", config_text(with(base_config(), "levels", "0")));
    try {
        read_foveation_config(bad);
        FAIL() << "levels 0 was accepted";
    } catch (const Error& error) {
        EXPECT_EQ(error.where(), bad.string() + ": levels");
    }
    try {
        read_foveation_config(dir / "absent.json");
        FAIL() << "a missing file was read";
    } catch (const Error& error) {
        EXPECT_EQ(error.where(), (dir / "absent.json").string());
        EXPECT_EQ(error.reason(), "no such file");
    }
    // A directory once read as an empty stream and was reported as invalid JSON.
    std::filesystem::create_directory(dir / "folder.json");
    try {
        read_foveation_config(dir / "folder.json");
        FAIL() << "a directory was read";
    } catch (const Error& error) {
        EXPECT_EQ(std::string(error.what()), (dir / "folder.json").string() + ": is a directory");
    }
}

TEST(FoveationConfig, ModeAndDownsampleNames)
{
    for (FoveationMode mode :
         {FoveationMode::none, FoveationMode::single, FoveationMode::raw, FoveationMode::mfpc}) {
        EXPECT_EQ(parse_foveation_mode(to_string(mode)), mode);
    }
    for (Downsample downsample : {Downsample::voxel, Downsample::uniform}) {
        EXPECT_EQ(parse_downsample(to_string(downsample)), downsample);
    }
    try {
        parse_foveation_mode("MFPC", "--mode");
        FAIL();
    } catch (const Error& error) {
        EXPECT_EQ(error.where(), "--mode");
        EXPECT_NE(error.reason().find("'MFPC'"), std::string::npos);
    }
    EXPECT_THROW(parse_downsample("grid"), Error);
}

// The shipped example configs, for the shared real scenes (examples/configs/README.md).
std::filesystem::path example_configs_dir()
{
    return std::filesystem::path(__FILE__).parent_path().parent_path().parent_path() / "examples" /
           "configs";
}

TEST(FoveationConfig, ShippedExamplesParseWithoutWarnings)
{
    const auto dir = example_configs_dir();
    ASSERT_TRUE(std::filesystem::is_directory(dir)) << dir;
    std::size_t count = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        if (entry.path().extension() != ".json") continue;
        ++count;
        SCOPED_TRACE(entry.path().string());
        std::vector<std::string> warnings;
        FoveationConfig config;
        ASSERT_NO_THROW(config = read_foveation_config(entry.path(), FoveaPolicy::strict, &warnings));
        EXPECT_TRUE(warnings.empty());
        for (const FoveatedStructure& structure : config.structures) {
            EXPECT_FALSE(structure.name.empty());
            EXPECT_TRUE(structure.outer_box().contains(structure.level_box(config.levels())));
        }
    }
    EXPECT_GE(count, 3u);
}

// The examples are placed for the shared scenes: each fovea holds its whole carton (the model's
// points at their ground-truth poses), so recognition runs at the fovea's density there.
TEST(FoveationConfig, ShippedExampleFoveaeHoldTheCartons)
{
    MFPC_SHARED_FILE_OR_SKIP(model_path, "milk.pcd");
    MFPC_SHARED_FILE_OR_SKIP(truth_path, "milk_pair.gt.json");
    const PointCloud model = read_cloud(model_path);
    std::ifstream truth_file(truth_path);
    const auto truth = nlohmann::json::parse(truth_file);
    ASSERT_EQ(truth["instances"].size(), 2u);
    std::vector<std::vector<Point>> cartons;
    for (const auto& instance : truth["instances"]) {
        const std::vector<double> matrix = instance["transform"].get<std::vector<double>>();
        const Pose pose = pose_from_row_major(matrix, truth_path.string());
        std::vector<Point> carton;
        for (const Point& p : model.points) carton.push_back(pose * p);
        cartons.push_back(std::move(carton));
    }

    const auto fovea_holds = [](const FoveatedStructure& structure, const std::vector<Point>& points) {
        const Box fovea = structure.level_box(structure.levels);
        return std::all_of(points.begin(), points.end(),
                           [&](const Point& p) { return fovea.contains(p); });
    };
    const auto dir = example_configs_dir();
    const FoveationConfig whole = read_foveation_config(dir / "scene_whole.json");
    ASSERT_EQ(whole.structures.size(), 1u);
    EXPECT_TRUE(fovea_holds(whole.structures[0], cartons[0]));

    const FoveationConfig two = read_foveation_config(dir / "milk_pair_two.json");
    ASSERT_EQ(two.structures.size(), 2u);
    EXPECT_TRUE(fovea_holds(two.structures[0], cartons[0]));
    EXPECT_TRUE(fovea_holds(two.structures[1], cartons[1]));
    // One structure per carton: neither fovea reaches the other carton.
    EXPECT_FALSE(two.structures[0].level_box(3).contains(cartons[1][0]));
    EXPECT_FALSE(two.structures[1].level_box(3).contains(cartons[0][0]));

    const FoveationConfig both = read_foveation_config(dir / "milk_pair_cover_both.json");
    ASSERT_EQ(both.structures.size(), 1u);
    EXPECT_TRUE(fovea_holds(both.structures[0], cartons[0]));
    EXPECT_TRUE(fovea_holds(both.structures[0], cartons[1]));
}

}  // namespace
}  // namespace mfpc
