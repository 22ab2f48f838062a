// Writes the seed corpora of the fuzz targets, corpus/<target>/, with the library's own writers
// where it has them (clouds, meshes through sample-free text, PNGs, model caches, configs) and
// small hand-written files where the format is a user's (ground truth, manifests, lists), so the
// seeds are the project's own and can be made again:
//
//     build/release/tests/fuzz/mfpc_fuzz_seeds tests/fuzz/corpus
//
// Deterministic: the same build writes the same bytes. Each seed is a few KB at most, so a fuzzer
// starts from well-formed input of every kind its reader takes.
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/foveation_config.hpp"
#include "mfpc/kernels/shot.hpp"
#include "mfpc/recognition/model.hpp"
#include "mfpc/recognition/params.hpp"
#include "mfpc/rendering/png_image.hpp"
#include "mfpc/simulation/mesh.hpp"

namespace {

using namespace mfpc;
namespace fs = std::filesystem;

fs::path root;

fs::path seed_path(const std::string& target, const std::string& name)
{
    const fs::path dir = root / target;
    fs::create_directories(dir);
    return dir / name;
}

void write_text(const std::string& target, const std::string& name, const std::string& text)
{
    std::ofstream out(seed_path(target, name), std::ios::binary | std::ios::trunc);
    out << text;
}

std::string read_bytes(const fs::path& path)
{
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

// A small curved patch (part of a sphere), the shape a sensor sees, with normals and colours.
PointCloud patch(std::size_t side, bool normals, bool colors)
{
    PointCloud cloud;
    for (std::size_t v = 0; v < side; ++v) {
        for (std::size_t u = 0; u < side; ++u) {
            const float x = -0.05f + 0.1f * float(u) / float(side), y = -0.05f + 0.1f * float(v) / float(side);
            const Point p(x, y, 1.0f + 2 * (x * x + y * y));
            cloud.points.push_back(p);
            if (normals) cloud.normals.push_back(Point(4 * x, 4 * y, -1).normalized());
            if (colors) cloud.colors.push_back({std::uint8_t(40 * u), std::uint8_t(40 * v), 200});
        }
    }
    cloud.width = std::uint32_t(cloud.size());
    return cloud;
}

// An organized 6 x 4 grid with two holes (NaN pixels in the file): the index map keeps positions.
PointCloud organized()
{
    PointCloud cloud;
    cloud.width = 6;
    cloud.height = 4;
    for (std::uint32_t i = 0; i < 24; ++i) {
        if (i == 7 || i == 15) continue;
        cloud.points.emplace_back(0.01f * float(i % 6), 0.01f * float(i / 6), 0.9f);
        cloud.source_index.push_back(i);
    }
    return cloud;
}

void cloud_seeds()
{
    const CloudEncoding encodings[] = {CloudEncoding::ascii, CloudEncoding::binary, CloudEncoding::binary_compressed};
    for (const CloudEncoding encoding : encodings) {
        const std::string name = to_string(encoding);
        write_cloud(seed_path("fuzz_read_pcd", name + ".pcd"), patch(4, false, false), {encoding, false});
        write_cloud(seed_path("fuzz_read_pcd", name + "_normals_rgb.pcd"), patch(3, true, true), {encoding, false});
        write_cloud(seed_path("fuzz_read_pcd", name + "_organized.pcd"), organized(), {encoding, true});
        if (encoding != CloudEncoding::binary_compressed) {
            write_cloud(seed_path("fuzz_read_ply", name + ".ply"), patch(4, false, false), {encoding, false});
            write_cloud(seed_path("fuzz_read_ply", name + "_normals_rgb.ply"), patch(3, true, true), {encoding, false});
        }
    }
    // The big-endian binary PLY other tools write, by hand (the writer writes little endian).
    std::string big = "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                      "property float z\nend_header\n";
    for (int i = 0; i < 3; ++i) {
        const float xyz[3] = {0.01f * float(i), 0.02f, 1.0f};
        for (float value : xyz) {
            unsigned char bytes[4];
            std::memcpy(bytes, &value, 4);
            for (int b = 3; b >= 0; --b) big.push_back(char(bytes[b]));
        }
    }
    write_text("fuzz_read_ply", "binary_big_endian.ply", big);

    // The compressed target's input: its three header bytes (width - 1 as 16 bits, 1 for height 1,
    // the field layout), then the data section of a binary_compressed file the writer made.
    const struct {
        const char* name;
        PointCloud cloud;
        char layout;
    } compressed[] = {{"xyz", patch(4, false, false), 0}, {"xyz_rgb", patch(3, false, true), 1}};
    for (const auto& [name, cloud, layout] : compressed) {
        const fs::path file = fs::temp_directory_path() / "mfpc_seed.pcd";
        write_cloud(file, cloud, {CloudEncoding::binary_compressed, false});
        const std::string bytes = read_bytes(file);
        fs::remove(file);
        const std::string marker = "DATA binary_compressed\n";
        const std::size_t width = cloud.size() - 1;
        std::string seed{char(width & 0xff), char(width >> 8), 1, 0, layout};
        seed += bytes.substr(bytes.find(marker) + marker.size());
        write_text("fuzz_read_pcd_compressed", std::string(name) + ".bin", seed);
    }
}

void mesh_seeds()
{
    // The built-in box, written as the formats read_mesh takes (there is no mesh writer: a mesh is
    // an input of synth, never an output).
    const TriangleMesh mesh = make_builtin_object("box");
    std::ostringstream ply, obj;
    ply << "ply\nformat ascii 1.0\ncomment built-in box\nelement vertex " << mesh.vertices.size()
        << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << mesh.triangles.size()
        << "\nproperty list uchar int vertex_indices\nend_header\n";
    obj << "# built-in box\no box\n";
    for (const auto& v : mesh.vertices) {
        ply << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
        obj << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    }
    for (const auto& t : mesh.triangles) {
        ply << "3 " << t.x() << ' ' << t.y() << ' ' << t.z() << '\n';
        obj << "f " << t.x() + 1 << "//1 " << t.y() + 1 << "//1 " << -int(mesh.vertices.size()) + t.z() << '\n';
    }
    write_text("fuzz_read_mesh_ply", "box_ascii.ply", ply.str());
    write_text("fuzz_read_mesh_obj", "box.obj", obj.str());
    write_text("fuzz_read_mesh_obj", "quad.obj", "v 0 0 0\nv 0.1 0 0\nv 0.1 0.1 0\nv 0 0.1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1 4/1/1\n");
    // A binary little-endian tetrahedron with double coordinates and an extra property.
    std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
                         "property double z\nproperty uchar red\nelement face 4\nproperty list uchar uint vertex_indices\n"
                         "end_header\n";
    const double vertices[4][3] = {{0, 0, 0}, {0.1, 0, 0}, {0, 0.1, 0}, {0, 0, 0.1}};
    for (const auto& v : vertices) {
        binary.append(reinterpret_cast<const char*>(v), sizeof v);
        binary.push_back(char(200));
    }
    const std::uint32_t faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    for (const auto& f : faces) {
        binary.push_back(3);
        binary.append(reinterpret_cast<const char*>(f), sizeof f);
    }
    write_text("fuzz_read_mesh_ply", "tetra_binary.ply", binary);
}

void config_seeds()
{
    FoveationConfig one;
    one.structures.emplace_back();
    one.structures[0].outer_min = Point(-0.5f, -0.4f, 0.6f);
    one.structures[0].outer_size = Point(1, 0.8f, 1.2f);
    one.structures[0].fovea_size = Point(0.2f, 0.2f, 0.3f);
    one.structures[0].fovea_offset = Point(0.1f, -0.05f, 0.2f);
    one.structures[0].name = "carton";
    write_text("fuzz_foveation_config", "one.json", to_json(one));
    FoveationConfig two = one;
    two.downsample = Downsample::uniform;
    two.structures.push_back(one.structures[0]);
    two.structures[1].outer_min = Point(0, -0.4f, 0.6f);
    two.structures[1].density_outer = 0;
    two.structures[1].name = "";
    for (FoveatedStructure& s : two.structures) s.levels = 4;
    write_text("fuzz_foveation_config", "two.json", to_json(two));
    write_text("fuzz_foveation_config", "center.json",
               R"({"levels": 2, "downsample": "voxel", "structures": [{"outer_min": [0, 0, 0], "outer_size": [1, 1, 1],
  "fovea_size": [0.5, 0.5, 0.5], "fovea_center": [0.9, 0.5, 0.5], "density": [0.02, 0.005], "keypoint_radius": [0.03, 0.01]}]}
)");

    write_text("fuzz_recognition_params", "defaults.json", to_json(RecognitionParams{}));
    write_text("fuzz_recognition_params", "empty.json", "{}\n");
    write_text("fuzz_recognition_params", "partial.json",
               R"({"scene": {"resolution": 0.004, "keypoint_radius": 0.02}, "normals_from": "scene"})" "\n");

    const std::string identity = "[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]";
    write_text("fuzz_ground_truth", "two.gt.json",
               R"({"model": "carton.pcd", "instances": [{"transform": )" + identity +
                   R"(, "object": "carton", "visible_points": 1200, "visible_fraction": 0.8},
  {"transform": [0, -1, 0, 0.1, 1, 0, 0, -0.2, 0, 0, 1, 1.5, 0, 0, 0, 1], "symmetry": {"axis": [0, 0, 1], "order": 2, "flip": {"axis": [1, 0, 0], "point": [0, 0, 0.13]}}}]}
)");
    write_text("fuzz_ground_truth", "none.gt.json", R"({"instances": []})" "\n");
    write_text("fuzz_instance_poses", "result.json",
               R"({"model": "carton.pcd", "instances": [{"transform": )" + identity + R"(, "votes": 12}]})" "\n");
    write_text("fuzz_instance_poses", "truth.json",
               R"({"model": "m.pcd", "instances": [{"transform": [0, -1, 0, 0.1, 1, 0, 0, -0.2, 0, 0, 1, 1.5, 0, 0, 0, 1]}]})" "\n");

    write_text("fuzz_experiment_config", "experiment.json",
               R"({"model": "model.pcd", "scene": "scene.pcd", "ground_truth": "scene.gt.json", "params": {},
  "runs": 3, "reference": "MFPC",
  "strategies": [{"name": "plain", "mode": "none"}, {"name": "MFPC", "mode": "mfpc", "fovea": "fovea.json"},
                 {"name": "one", "mode": "single", "fovea": "fovea.json", "structure": 0},
                 {"name": "serial", "mode": "serial", "fovea": "fovea.json"}]}
)");
    write_text("fuzz_experiment_config", "params_file.json",
               R"({"model": "m.mfpcm", "scene": "s.ply", "ground_truth": "s.gt.json", "params": "params.json",
  "strategies": [{"name": "auto", "mode": "mfpc", "fovea": "auto", "placement": "model"}]}
)");

    write_text("fuzz_dataset", "set.json",
               R"({"name": "seeds", "data_dir": "data", "models": [{"name": "milk", "file": "milk.pcd"}, {"file": "box.mfpcm"}],
  "scenes": [{"cloud": "a.pcd", "model": "milk", "ground_truth": "a.gt.json", "fovea": "a.fovea.json", "group": "near"},
             {"name": "b", "cloud": "b.ply", "model": "box", "negative": true}]}
)");
    write_text("fuzz_dataset", "one_model.json",
               R"({"models": [{"file": "m.pcd"}], "scenes": [{"cloud": "s.pcd", "ground_truth": "s.gt.json"}]})" "\n");

    write_text("fuzz_scene_list", "list.txt", "# scenes\na.ply\n\nb.ply\n*.ply\n./a.ply\n");
    write_text("fuzz_scene_list", "glob.txt", "[ab].ply\n?.ply\n");
    write_text("fuzz_batch_output", "records.jsonl",
               R"({"scene":"a.pcd","status":"ok","models":[{"model":"milk","instances":1}]})" "\n"
               R"({"scene":"b.pcd","status":"error","error":"b.pcd: no points"})" "\n");
    write_text("fuzz_batch_output", "torn.jsonl", R"({"scene":"a.pcd","status":"ok"})" "\n" R"({"scene":"b.p)");
}

void model_seed()
{
    // A hand-made model of the fewest parts a cache holds: 16 points, 3 keypoints with identity
    // frames and unit descriptors (a prepared model holds thousands of points: too big a seed).
    Model model;
    model.source = "seed";
    for (int i = 0; i < 16; ++i) {
        model.points.emplace_back(0.01f * float(i % 4), 0.01f * float(i / 4), 0.0f);
        model.normals.emplace_back(0, 0, 1);
    }
    for (int k = 0; k < 3; ++k) {
        model.features.keypoints.push_back(model.points[std::size_t(5 * k)]);
        model.features.frames.push_back(LocalReferenceFrame::Identity());
        std::vector<float> descriptor(shot_size, 0.0f);
        descriptor[std::size_t(k * 100)] = 1.0f;
        model.features.descriptors.insert(model.features.descriptors.end(), descriptor.begin(), descriptor.end());
    }
    model.features.candidates = 3;
    model.params = RecognitionParams{}.model;
    write_model_cache(seed_path("fuzz_model_cache", "small.mfpcm"), model);
}

void png_seeds()
{
    RgbImage image;
    image.width = 4;
    image.height = 3;
    for (std::uint32_t i = 0; i < 12; ++i) image.pixels.insert(image.pixels.end(), {std::uint8_t(20 * i), 100, 200});
    write_png(seed_path("fuzz_png", "rgb.png"), image);
    const std::vector<std::uint16_t> gray = {0, 1, 2, 65535, 300, 4000};
    write_png_gray16(seed_path("fuzz_png", "gray16.png"), 3, 2, gray);
}

// The library-level targets read their bytes as numbers (fuzz_support.hpp, Bytes): any bytes are
// an input, and a few random ones of several lengths give the fuzzer clouds of several sizes.
void byte_seeds()
{
    const char* targets[] = {"fuzz_foveate", "fuzz_descriptors", "fuzz_cloud_stats", "fuzz_recognize",
                             "fuzz_render", "fuzz_scanner", "fuzz_organized_nearest", "fuzz_placement"};
    std::mt19937 rng(32);
    for (const char* target : targets) {
        for (const std::size_t size : {64u, 600u, 1800u}) {
            std::string bytes(size, '\0');
            for (char& b : bytes) b = char(rng());
            write_text(target, "random_" + std::to_string(size) + ".bin", bytes);
        }
    }
}

}  // namespace

int main(int argc, char** argv)
{
    if (argc != 2) {
        std::fprintf(stderr, "usage: mfpc_fuzz_seeds CORPUS_DIR\n");
        return 2;
    }
    root = argv[1];
    try {
        cloud_seeds();
        mesh_seeds();
        config_seeds();
        model_seed();
        png_seeds();
        byte_seeds();
    } catch (const mfpc::Error& error) {
        std::fprintf(stderr, "mfpc_fuzz_seeds: %s\n", error.what());
        return 1;
    }
    return 0;
}
