// Every file reader against thousands of damaged files: bytes flipped, cut, repeated, numbers
// swapped for extreme ones, header lines swapped. Each must read the file or throw mfpc::Error;
// any other exception fails here, and under the sanitizer preset so does any memory error or
// undefined behaviour on the way (a fuzzer run over these readers found one in the model cache).
// The seeds are written by the project's own writers; the mutations come from a fixed seed, so
// a failure names an input that can be made again.
#include <cctype>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <typeinfo>
#include <vector>

#include <gtest/gtest.h>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/core/detail/text_file.hpp"
#include "mfpc/recognition/experiment.hpp"
#include "mfpc/recognition/ground_truth.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/simulation/mesh.hpp"
#include "mfpc/rendering/png_image.hpp"
#include "test_support.hpp"

namespace mfpc {
namespace {

// Tokens a parser meets at its limits: out-of-range and special numbers, JSON and PCD syntax.
const std::vector<std::string> tokens = {
    "0",  "-1",   "1e309", "-1e309", "nan",  "inf", "4294967295", "4294967296", "18446744073709551616", "2147483647",
    "-0", "1e38", "1e-320", "",      " ",    "\n",  "\"",         "{",          "}",                    "[",
    "]",  ",",    ":",     "null",   "true", "F",   "U",          "I",          "8",                    "ascii",
    "binary", "binary_compressed", std::string("\xff\xff\xff\xff", 4), std::string(4, '\0')};

std::string mutate(std::string bytes, std::mt19937_64& rng)
{
    const int edits = 1 + int(rng() % 4);
    for (int e = 0; e < edits; ++e) {
        if (bytes.empty()) {
            bytes = "x";
            continue;
        }
        const std::size_t at = rng() % bytes.size();
        switch (rng() % 8) {
        case 0: bytes[at] = char(rng()); break;
        case 1: bytes[at] = char(bytes[at] ^ (1 << (rng() % 8))); break;
        case 2: bytes.erase(at, 1 + rng() % 16); break;
        case 3: {
            const std::string copy = bytes.substr(at, 1 + rng() % 32);
            bytes.insert(rng() % bytes.size(), copy);
            break;
        }
        case 4: bytes.insert(at, tokens[rng() % tokens.size()]); break;
        case 5: {  // a number replaced by one of the extreme tokens
            std::size_t begin = at;
            while (begin < bytes.size() && !std::isdigit(static_cast<unsigned char>(bytes[begin]))) ++begin;
            std::size_t end = begin;
            while (end < bytes.size() && std::strchr("0123456789.e-", bytes[end]) != nullptr && bytes[end] != '\0')
                ++end;
            if (begin < bytes.size()) bytes.replace(begin, end - begin, tokens[rng() % 12]);
            break;
        }
        case 6: bytes.resize(at); break;
        case 7: {  // two neighbouring lines swapped (header keys out of order)
            const std::size_t first_end = bytes.find('\n', at);
            if (first_end == std::string::npos) break;
            const std::size_t second_end = bytes.find('\n', first_end + 1);
            if (second_end == std::string::npos) break;
            const std::string first = bytes.substr(at, first_end - at);
            const std::string second = bytes.substr(first_end + 1, second_end - first_end - 1);
            bytes.replace(at, second_end - at, second + "\n" + first);
            break;
        }
        }
    }
    return bytes;
}

// `rounds` mutations of each seed (each passed through `fix` when given), written to `name` in
// `dir` and given to `read`.
struct Mutations {
    int rounds = 0;
    std::uint64_t seed = 0;
    std::function<std::string(std::string)> fix = {};
    bool some_read = true;  // expect some mutated files to read (false where a checksum guards them)
};

void expect_only_mfpc_errors(const test::TempDir& dir, const std::string& name, const std::vector<std::string>& seeds,
                             const std::function<void(const std::filesystem::path&)>& read, const Mutations& how)
{
    const int rounds = how.rounds;
    const auto& fix = how.fix;
    const std::uint64_t seed = how.seed;
    std::mt19937_64 rng(seed);
    int read_ok = 0, refused = 0;
    for (std::size_t s = 0; s < seeds.size(); ++s) {
        for (int round = 0; round < rounds; ++round) {
            std::string bytes = mutate(seeds[s], rng);
            if (fix) bytes = fix(std::move(bytes));
            const auto file = dir.write(name, bytes);
            try {
                read(file);
                ++read_ok;
            } catch (const Error&) {
                ++refused;
            } catch (const std::exception& e) {
                FAIL() << name << ", seed file " << s << ", round " << round << ": " << typeid(e).name() << ": "
                       << e.what();
            }
        }
    }
    // Both outcomes occur: the mutations are neither all harmless nor all fatal.
    EXPECT_GT(refused, 0) << name;
    if (how.some_read) {
        EXPECT_GT(read_ok, 0) << name;
    }
}

PointCloud small_cloud(bool organized)
{
    PointCloud cloud;
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    cloud.width = organized ? 6 : 20;
    cloud.height = organized ? 4 : 1;
    for (std::uint32_t i = 0; i < cloud.source_size(); ++i) {
        if (organized && i % 5 == 2) continue;  // pixels without depth
        cloud.points.emplace_back(unit(rng), unit(rng), 1.5f + unit(rng));
        cloud.normals.push_back(Point(unit(rng), unit(rng), 1.0f).normalized());
        cloud.colors.push_back({std::uint8_t(i * 11), std::uint8_t(i * 37), std::uint8_t(i * 73)});
        if (organized) cloud.source_index.push_back(i);
    }
    return cloud;
}

TEST(MutatedInputs, CloudFilesReadOrFailWithOneError)
{
    const test::TempDir dir;
    for (const char* extension : {".pcd", ".ply"}) {
        std::vector<std::string> seeds;
        for (const CloudEncoding encoding : {CloudEncoding::ascii, CloudEncoding::binary, CloudEncoding::binary_compressed}) {
            if (encoding == CloudEncoding::binary_compressed && std::string(extension) == ".ply") continue;
            for (const bool organized : {false, true}) {
                if (organized && std::string(extension) == ".ply") continue;
                const auto file = dir / (std::string("seed") + extension);
                write_cloud(file, small_cloud(organized), {encoding, organized});
                seeds.push_back(read_text_file(file));
            }
        }
        expect_only_mfpc_errors(dir, std::string("mutated") + extension, seeds, [](const auto& f) { read_cloud(f); },
                                {400, 1});
    }
}

TEST(MutatedInputs, MeshFilesReadOrFailWithOneError)
{
    const test::TempDir dir;
    const std::string obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nf 1 2 3\nf 1//1 3//1 4//1\nf -1 -2 -3\n";
    const std::string ply_ascii = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
                                  "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
                                  "end_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n4 0 1 2 3\n";
    std::string ply_binary = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty double x\n"
                             "property double y\nproperty double z\nelement face 1\n"
                             "property list uchar int vertex_indices\nend_header\n";
    for (const double v : {0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0})
        ply_binary.append(reinterpret_cast<const char*>(&v), sizeof v);
    ply_binary += char(3);
    for (const std::int32_t i : {0, 1, 2}) ply_binary.append(reinterpret_cast<const char*>(&i), sizeof i);
    expect_only_mfpc_errors(dir, "mutated.obj", {obj}, [](const auto& f) { read_mesh(f); }, {1500, 2});
    expect_only_mfpc_errors(dir, "mutated.ply", {ply_ascii, ply_binary}, [](const auto& f) { read_mesh(f); }, {800, 3});
}

TEST(MutatedInputs, JsonFilesReadOrFailWithOneError)
{
    const test::TempDir dir;
    const std::filesystem::path configs = std::filesystem::path(MFPC_SOURCE_DIR) / "examples/configs";
    std::vector<std::string> fovea_seeds;
    for (const char* name : {"milk_carton.json", "milk_pair_two.json"})
        fovea_seeds.push_back(read_text_file(configs / name));
    expect_only_mfpc_errors(dir, "fovea.json", fovea_seeds, [](const auto& f) { read_foveation_config(f); },
                            {700, 4});

    const std::string params_seed = to_json(RecognitionParams{});
    const std::string tutorial = read_text_file(std::filesystem::path(MFPC_SOURCE_DIR) / "examples/params/pcl_tutorial.json");
    expect_only_mfpc_errors(dir, "params.json", {params_seed, tutorial},
                            [](const auto& f) { read_recognition_params(f); }, {700, 5});

    const std::string truth =
        R"({"model": "milk.pcd", "instances": [{"transform": [1, 0, 0, 0.1, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1], )"
        R"("object": "carton", "visible_points": 1200, "symmetry": {"axis": [0, 0, 1], "order": 2}}]})";
    expect_only_mfpc_errors(dir, "truth.json", {truth}, [](const auto& f) { read_ground_truth(f); }, {1500, 6});

    // An experiment names files beside it; the fovea file is read with it.
    dir.write("fovea_ok.json", fovea_seeds[0]);
    for (const char* name : {"model.pcd", "scene.pcd", "scene.gt.json"}) dir.write(name, "");
    const std::string experiment =
        R"({"model": "model.pcd", "scene": "scene.pcd", "ground_truth": "scene.gt.json", "runs": 3, )"
        R"("reference": "MFPC", "params": {"scene": {"normal_k": 12}}, "strategies": [{"name": "plain", "mode": "none"}, )"
        R"({"name": "MFPC", "mode": "mfpc", "fovea": "fovea_ok.json"}, )"
        R"({"name": "one", "mode": "single", "fovea": "fovea_ok.json", "structure": 0}]})";
    expect_only_mfpc_errors(dir, "experiment.json", {experiment}, [](const auto& f) { read_experiment_config(f); },
                            {1500, 7});
}

std::uint64_t fnv1a(const std::string& bytes)
{
    std::uint64_t hash = 0xcbf29ce484222325ull;
    for (const char c : bytes) hash = (hash ^ std::uint8_t(c)) * 0x100000001b3ull;
    return hash;
}

TEST(MutatedInputs, ModelCachesReadOrFailWithOneError)
{
    const test::TempDir dir;
    // Few keypoints, so a small cache.
    FeatureParams params = RecognitionParams{}.model;
    params.keypoint_radius = 0.03f;
    const Model model = prepare_model(sample_surface(make_builtin_object("carton"), 0.006f, 1), params, "carton.pcd");
    write_model_cache(dir / "seed.mfpcm", model);
    const std::string cache = read_text_file(dir / "seed.mfpcm");
    // Damage that the checksum finds, then damage behind a valid checksum (the first 256 bytes
    // hold the parameters and the array sizes), which only the reader's own checks can find.
    const auto read = [](const auto& f) { read_model_cache(f); };
    expect_only_mfpc_errors(dir, "damaged.mfpcm", {cache}, read, {200, 8, {}, false});
    const std::string head = cache.substr(0, 256);
    const std::string body = cache.substr(256, cache.size() - 8 - 256);
    const auto resum = [&](std::string mutated_head) {
        std::string bytes = mutated_head + body;
        const std::uint64_t sum = fnv1a(bytes);
        return bytes.append(reinterpret_cast<const char*>(&sum), sizeof sum);
    };
    expect_only_mfpc_errors(dir, "forged.mfpcm", {head}, read, {600, 9, resum});
}

TEST(MutatedInputs, PngFilesReadOrFailWithOneError)
{
    const test::TempDir dir;
    RgbImage image{5, 3, {}};
    for (std::uint8_t i = 0; i < 45; ++i) image.pixels.push_back(std::uint8_t(i * 5));
    write_png(dir / "rgb.png", image);
    const std::vector<std::uint16_t> depth = {0, 1, 2, 300, 4000, 50000, 65535, 7, 8, 9, 10, 11};
    write_png_gray16(dir / "gray.png", 4, 3, depth);
    const std::vector<std::string> seeds = {read_text_file(dir / "rgb.png"), read_text_file(dir / "gray.png")};
    expect_only_mfpc_errors(dir, "rgb_mutated.png", seeds, [](const auto& f) { read_png_rgb(f); }, {400, 10});
    expect_only_mfpc_errors(dir, "gray_mutated.png", seeds, [](const auto& f) {
        std::uint32_t width = 0, height = 0;
        read_png_gray16(f, &width, &height);
    }, {400, 11});
}

}  // namespace
}  // namespace mfpc
