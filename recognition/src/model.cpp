#include "mfpc/recognition/model.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <string>

#include "mfpc/core/detail/atomic_file.hpp"
#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/text_file.hpp"
#include "mfpc/index/distinct_points.hpp"
#include "mfpc/index/neighbor_grid.hpp"
#include "mfpc/kernels/normals.hpp"
#include "mfpc/kernels/shot.hpp"
#include "mfpc/kernels/uniform_sampling.hpp"
#include "mfpc/recognition/verification.hpp"

namespace mfpc {
namespace {

constexpr char magic[8] = {'M', 'F', 'P', 'C', 'M', 'O', 'D', 'L'};

std::uint64_t fnv1a(const char* data, std::size_t size)
{
    std::uint64_t hash = 0xcbf29ce484222325ull;
    for (std::size_t i = 0; i < size; ++i) {
        hash ^= std::uint8_t(data[i]);
        hash *= 0x100000001b3ull;
    }
    return hash;
}

class Writer {
public:
    template <class T> void value(const T& v) { bytes_.append(reinterpret_cast<const char*>(&v), sizeof(T)); }
    template <class T> void array(const std::vector<T>& v)
    {
        value(std::uint64_t(v.size()));
        bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
    }
    std::string& bytes() { return bytes_; }

private:
    std::string bytes_;
};

class Reader {
public:
    Reader(const std::string& bytes, std::size_t end, std::string where)
        : bytes_(bytes), end_(end), where_(std::move(where))
    {
    }
    template <class T> T value()
    {
        need(sizeof(T));
        T v;
        std::memcpy(&v, bytes_.data() + at_, sizeof(T));
        at_ += sizeof(T);
        return v;
    }
    template <class T> std::vector<T> array(std::uint64_t expected_count = ~0ull)
    {
        const auto count = value<std::uint64_t>();
        if (expected_count != ~0ull && count != expected_count)
            throw Error(where_, "corrupt model cache: an array holds " + std::to_string(count) + " entries, expected " +
                                    std::to_string(expected_count));
        if (count > (end_ - at_) / sizeof(T)) throw Error(where_, "truncated or corrupt model cache");
        std::vector<T> v(count);
        // An empty vector's data() may be null, which memcpy must not get even for 0 bytes.
        if (count != 0) std::memcpy(static_cast<void*>(v.data()), bytes_.data() + at_, count * sizeof(T));
        at_ += count * sizeof(T);
        return v;
    }
    std::size_t position() const { return at_; }

private:
    void need(std::size_t n) const
    {
        if (end_ - at_ < n) throw Error(where_, "truncated or corrupt model cache");
    }
    const std::string& bytes_;
    std::size_t end_;
    std::size_t at_ = 0;
    std::string where_;
};

template <class T> bool all_finite(const std::vector<T>& v)
{
    for (const auto& x : v)
        if (!x.allFinite()) return false;
    return true;
}

}  // namespace

Point model_centroid(const Model& model)
{
    if (model.points.empty()) return Point::Zero();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const Point& p : model.points) sum += p.cast<double>();
    return (sum / double(model.points.size())).cast<float>();
}

void prepare_model_verification(Model& model, const RecognitionParams& params)
{
    model.verification = prepare_verification(model.points, model.normals, params.refine, params.verify);
}

Model prepare_model(const PointCloud& input, const FeatureParams& params, const std::string& source,
                    FeatureTimings* timings)
{
    if (input.empty()) throw Error(source, "the model cloud has no finite points");
    // Each position once, as for a scene (describe_scene): copies would make the normals' search
    // quadratic and add nothing to the surface.
    const DistinctPoints distinct = distinct_points(input.points);
    const PointCloud distinct_cloud =
        distinct.all_distinct() ? PointCloud{} : select(input, distinct.representatives(input.size()));
    const PointCloud& cloud = distinct.all_distinct() ? input : distinct_cloud;
    Model model;
    model.points = cloud.points;
    model.params = params;
    model.source = source;
    model.normals.resize(model.points.size());
    const NeighborGrid grid(model.points, normal_grid_cell);
    estimate_normals(model.points, grid, NormalParams{params.normal_k, Point::Zero()}, model.normals);
    // A model with normals of its own (sampled all around an object) is oriented by them; a view
    // from a sensor (no normals) faces the sensor at the origin.
    const std::span<const Point> orientation = cloud.has_normals() ? std::span<const Point>(cloud.normals)
                                                                   : std::span<const Point>();
    if (!orientation.empty()) orient_normals(model.normals, orientation);
    if (params.resolution > 0.0f) {
        model.features = describe_at_resolution(model.points, params, timings, orientation);
    } else {
        const auto keypoints = uniform_sampling(model.points, params.keypoint_radius);
        model.features = describe_keypoints(model.points, keypoints, grid, params, timings, orientation);
    }
    require_model_keypoints(model.features, params, source);
    return model;
}

void require_model_keypoints(const Features& features, const FeatureParams& params, const std::string& where)
{
    if (features.size() >= 3) return;
    // Few keypoints sampled means an object small for the radius; many sampled but few valid,
    // supports too sparse or too thin (points on a line) for a frame.
    const std::string count = "the model has " + std::to_string(features.size()) + " usable keypoints (fewer than 3)";
    if (features.candidates < 3)
        throw Error(where,
                    count + ": is it too small for keypoint_radius " + format_number(params.keypoint_radius) + "?");
    throw Error(where, count + ": " + std::to_string(features.invalid) + " of its " +
                           std::to_string(features.candidates) +
                           " keypoints have no defined local reference frame or SHOT descriptor: too few points "
                           "within lrf_radius " + format_number(params.lrf_radius) + " and shot_radius " +
                           format_number(params.shot_radius) + ", or all on a line?");
}

bool is_model_cache(const std::filesystem::path& path) { return path.extension() == ".mfpcm"; }

Model load_model(const std::filesystem::path& path, const FeatureParams& params, bool check_cache_params,
                 const std::string& params_source, FeatureTimings* timings)
{
    if (!is_model_cache(path)) return prepare_model(read_cloud(path), params, path.string(), timings);
    Model model = read_model_cache(path);
    if (check_cache_params && model.params != params)
        throw Error(path.string(), "the cache was made with other model parameters than " + params_source +
                                       " gives: run `mfpc model` again with these parameters");
    return model;
}

std::string model_cache_bytes(const Model& model)
{
    Writer w;
    w.bytes().append(magic, sizeof magic);
    w.value(model_cache_version);
    w.value(model.params.resolution);
    w.value(std::int32_t(model.params.normal_k));
    w.value(model.params.keypoint_radius);
    w.value(model.params.lrf_radius);
    w.value(model.params.shot_radius);
    w.array(std::vector<char>(model.source.begin(), model.source.end()));
    w.array(model.points);
    w.array(model.normals);
    w.value(std::uint64_t(model.features.candidates));
    w.value(std::uint64_t(model.features.invalid));
    w.array(model.features.keypoints);
    w.array(model.features.frames);
    w.array(model.features.descriptors);
    const std::uint64_t checksum = fnv1a(w.bytes().data(), w.bytes().size());
    w.value(checksum);
    return std::move(w.bytes());
}

void write_model_cache(const std::filesystem::path& path, const Model& model)
{
    const std::string bytes = model_cache_bytes(model);
    write_file_atomically(path, [&](std::ofstream& out) { out.write(bytes.data(), std::streamsize(bytes.size())); });
}

Model read_model_cache(const std::filesystem::path& path)
{
    const std::string where = path.string();
    const std::string bytes = read_text_file(path);
    if (bytes.size() < sizeof magic + 4 || std::memcmp(bytes.data(), magic, sizeof magic) != 0)
        throw Error(where, "not an mfpc model cache (.mfpcm): wrong magic bytes");
    std::uint32_t version = 0;
    std::memcpy(&version, bytes.data() + sizeof magic, 4);
    if (version != model_cache_version)
        throw Error(where, "model cache format version " + std::to_string(version) + ", this mfpc reads version " +
                               std::to_string(model_cache_version) + ": run `mfpc model` again");
    if (bytes.size() < sizeof magic + 4 + 8) throw Error(where, "truncated model cache");
    const std::size_t body = bytes.size() - 8;
    std::uint64_t stored = 0;
    std::memcpy(&stored, bytes.data() + body, 8);
    if (stored != fnv1a(bytes.data(), body)) throw Error(where, "corrupt model cache: checksum mismatch");

    Reader r(bytes, body, where);
    r.value<std::array<char, sizeof magic>>();
    r.value<std::uint32_t>();
    Model model;
    model.params.resolution = r.value<float>();
    model.params.normal_k = r.value<std::int32_t>();
    model.params.keypoint_radius = r.value<float>();
    model.params.lrf_radius = r.value<float>();
    model.params.shot_radius = r.value<float>();
    const auto source = r.array<char>();
    model.source = std::string(source.begin(), source.end());
    model.points = r.array<Point>();
    model.normals = r.array<Point>(model.points.size());
    model.features.candidates = r.value<std::uint64_t>();
    model.features.invalid = r.value<std::uint64_t>();
    model.features.keypoints = r.array<Point>();
    model.features.frames = r.array<LocalReferenceFrame>(model.features.keypoints.size());
    model.features.descriptors = r.array<float>(model.features.keypoints.size() * shot_size);
    if (r.position() != body) throw Error(where, "corrupt model cache: trailing bytes");
    if (!all_finite(model.points) || !all_finite(model.features.keypoints) || !all_finite(model.features.frames))
        throw Error(where, "corrupt model cache: non-finite coordinates");
    // The checksum finds damage, not a cache written with bad values: a NaN descriptor would match
    // nothing and quietly cost the model keypoints, and bad parameters would describe the scene
    // with them.
    const auto& descriptors = model.features.descriptors;
    if (!std::all_of(descriptors.begin(), descriptors.end(), [](float v) { return std::isfinite(v); }))
        throw Error(where, "corrupt model cache: non-finite descriptor values");
    const FeatureParams& p = model.params;
    const auto positive = [](float r) { return std::isfinite(r) && r > 0.0f; };
    if (!(p.resolution >= 0.0f && p.resolution <= 0.1f))
        throw Error(where, "corrupt model cache: invalid parameters (resolution outside 0..0.1 m)");
    if (p.normal_k < 3 || !positive(p.keypoint_radius) || !positive(p.lrf_radius) || !positive(p.shot_radius))
        throw Error(where, "corrupt model cache: invalid parameters (normal_k below 3 or a radius not positive)");
    if (model.features.size() < 3) throw Error(where, "the cached model has fewer than 3 keypoints");
    // Verification places the model's points (a view model's keypoints come from its views, not
    // from them, so the two counts are otherwise unrelated), and the keypoint counts add up.
    if (model.points.empty()) throw Error(where, "corrupt model cache: no model points");
    if (model.features.candidates != model.features.size() + model.features.invalid)
        throw Error(where, "corrupt model cache: inconsistent keypoint counts");
    return model;
}

}  // namespace mfpc
