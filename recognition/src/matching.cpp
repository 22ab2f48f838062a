#include "mfpc/recognition/matching.hpp"

#include <algorithm>
#include <cstring>
#include <type_traits>
#include <memory>
#include <numeric>
#include <span>
#include <string>

#include <flann/flann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "mfpc/kernels/shot.hpp"

namespace mfpc {
namespace {

// One 8-lane vector: with AVX2 a single register, otherwise two SSE halves.
using Lanes = float __attribute__((vector_size(32)));

float lane_total(const Lanes& sum)
{
    return ((sum[0] + sum[4]) + (sum[1] + sum[5])) + ((sum[2] + sum[6]) + (sum[3] + sum[7]));
}

// The squared L2 distance of two descriptors, summed in 8 lanes instead of one running sum (3-4x
// faster on 352 floats) and still in a fixed order, so every search method gets the same value.
// The lane sums and the order they are added in are the same with AVX2 or SSE, so is every
// distance (no FMA contraction: avx2 does not enable fma); the version is chosen at load time. It
// gives up early, every 32 dimensions, once past `worst` (when positive): only a distance at or
// below worst is ever the full sum.
#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target_clones("avx2", "default")))
#endif
float descriptor_distance(const float* x, const float* y, std::size_t size, float worst)
{
    Lanes sum = {0, 0, 0, 0, 0, 0, 0, 0};
    std::size_t i = 0;
    for (; i + 32 <= size; i += 32) {
        for (std::size_t j = i; j < i + 32; j += 8) {
            Lanes a, b;
            std::memcpy(&a, x + j, 32);
            std::memcpy(&b, y + j, 32);
            const Lanes d = a - b;
            sum += d * d;
        }
        if (worst > 0) {
            const float partial = lane_total(sum);
            if (partial > worst) return partial;
        }
    }
    float rest = 0.0f;
    for (; i < size; ++i) rest += (x[i] - y[i]) * (x[i] - y[i]);
    return lane_total(sum) + rest;
}

// FLANN's distance functor over descriptor_distance.
struct ShotDistance {
    using is_kdtree_distance = bool;
    using ElementType = float;
    using ResultType = float;

    template <typename Iterator1, typename Iterator2>
    ResultType operator()(Iterator1 a, Iterator2 b, std::size_t size, ResultType worst = -1) const
    {
        if constexpr (!std::is_convertible_v<Iterator1, const float*> || !std::is_convertible_v<Iterator2, const float*>) {
            // FLANN's own bookkeeping (tree bounds in double): the plain sum.
            ResultType sum = 0;
            for (std::size_t i = 0; i < size; ++i) sum += ResultType((a[i] - b[i]) * (a[i] - b[i]));
            return sum;
        } else {
            return descriptor_distance(a, b, size, worst);
        }
    }

    template <typename U, typename V>
    ResultType accum_dist(const U& a, const V& b, int) const
    {
        return (a - b) * (a - b);
    }
};

// Dot products of `query_count` query rows with `data_count` data rows (shot_size floats each),
// row-major into dots. Tiles of 3 x 3 rows keep nine vector sums in registers, so each load serves
// three products; a ragged edge repeats its last row and drops those products. This is only a
// filter (the distances that decide are descriptor_distance's), so its rounding, FMA or not, and
// its vector width may differ from machine to machine.
template <class Vector, std::size_t tile>
[[gnu::always_inline]] inline void dot_tiles(const float* queries, std::size_t query_count, const float* data,
                                             std::size_t data_count, float* dots)
{
    constexpr std::size_t width = sizeof(Vector) / sizeof(float);
    static_assert(shot_size % width == 0);
    for (std::size_t q0 = 0; q0 < query_count; q0 += tile) {
        const float* q[tile];
        for (std::size_t r = 0; r < tile; ++r) q[r] = queries + std::min(q0 + r, query_count - 1) * shot_size;
        for (std::size_t d0 = 0; d0 < data_count; d0 += tile) {
            const float* d[tile];
            for (std::size_t r = 0; r < tile; ++r) d[r] = data + std::min(d0 + r, data_count - 1) * shot_size;
            Vector sum[tile][tile] = {};
            for (std::size_t i = 0; i < shot_size; i += width) {
                Vector a[tile], b[tile];
#pragma GCC unroll 3
                for (std::size_t r = 0; r < tile; ++r) {
                    std::memcpy(&a[r], q[r] + i, sizeof(Vector));
                    std::memcpy(&b[r], d[r] + i, sizeof(Vector));
                }
#pragma GCC unroll 3
                for (std::size_t r = 0; r < tile; ++r)
#pragma GCC unroll 3
                    for (std::size_t c = 0; c < tile; ++c) sum[r][c] += a[r] * b[c];
            }
            for (std::size_t r = 0; r < tile && q0 + r < query_count; ++r)
                for (std::size_t c = 0; c < tile && d0 + c < data_count; ++c) {
                    float total = 0.0f;
                    for (std::size_t l = 0; l < width; ++l) total += sum[r][c][l];
                    dots[(q0 + r) * data_count + d0 + c] = total;
                }
        }
    }
}

// Chosen at load time: 8-lane FMA where the machine has it (15 of the 16 vector registers), SSE's
// 4 lanes otherwise.
#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("avx2,fma"))) void dot_products(const float* queries, std::size_t query_count,
                                                     const float* data, std::size_t data_count, float* dots)
{
    dot_tiles<Lanes, 3>(queries, query_count, data, data_count, dots);
}
__attribute__((target("default")))
#endif
void dot_products(const float* queries, std::size_t query_count, const float* data, std::size_t data_count,
                  float* dots)
{
    using Quad = float __attribute__((vector_size(16)));
    dot_tiles<Quad, 3>(queries, query_count, data, data_count, dots);
}

// The up to k nearest data descriptors of each query with squared distance below threshold, by
// (distance, index), written as found/distances rows of k (-1 where fewer). An exhaustive scan:
// in 352 dimensions a kd-tree visits nearly every leaf anyway, and a scan can take the distances
// in bulk. Since |q - d|^2 = |q|^2 + |d|^2 - 2 q.d, blocked dot products rule out all but the few
// pairs near the acceptance bound; those get the exact distance.
void scan_nearest(const Features& data, const Features& queries, int k, float threshold, std::span<int> found,
                  std::span<float> distances)
{
    const auto squared_norms = [](const Features& f) {
        std::vector<float> norms(f.size());
        for (std::size_t i = 0; i < f.size(); ++i) {
            const auto v = f.descriptor(i);
            norms[i] = std::inner_product(v.begin(), v.end(), v.begin(), 0.0f);
        }
        return norms;
    };
    const std::vector<float> data_norms = squared_norms(data);
    const std::vector<float> query_norms = squared_norms(queries);
    // Query rows per task and data rows per block (multiples of the 3-row tile): the block (42 KB)
    // stays in cache while every query of the task passes over it (measured: about 32 rows beat 24,
    // 48 and 128). The simple partitioner keeps tasks at task_rows whatever the thread count.
    constexpr std::size_t task_rows = 48, block_rows = 30;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), task_rows), [&](const auto& range) {
        const std::size_t count = range.end() - range.begin();
        std::vector<float> dots(count * block_rows);
        std::vector<int> kept(count, 0);  // how many results each query has so far in found/distances
        for (std::size_t b0 = 0; b0 < data.size(); b0 += block_rows) {
            const std::size_t block = std::min(block_rows, data.size() - b0);
            dot_products(queries.descriptors.data() + range.begin() * shot_size, count,
                         data.descriptors.data() + b0 * shot_size, block, dots.data());
            for (std::size_t r = 0; r < count; ++r) {
                const std::size_t q = range.begin() + r;
                const float* query = queries.descriptors.data() + q * shot_size;
                int* hits = found.data() + q * std::size_t(k);
                float* hit_distances = distances.data() + q * std::size_t(k);
                int& n = kept[r];
                for (std::size_t c = 0; c < block; ++c) {
                    const std::size_t j = b0 + c;
                    const float worst = n < k ? threshold : hit_distances[k - 1];
                    // |estimate - exact distance| stays below about 3e-5 (|q|^2 + |d|^2) for 352
                    // terms in float, with or without FMA: the margin is 30 times that.
                    const float estimate = query_norms[q] + data_norms[j] - 2.0f * dots[r * block + c];
                    if (!(estimate < worst + 1e-3f * (query_norms[q] + data_norms[j]))) continue;
                    const float d2 = descriptor_distance(query, data.descriptors.data() + j * shot_size, shot_size, worst);
                    if (!(d2 < worst)) continue;  // a later index loses a tie
                    int at = std::min(n, k - 1);
                    while (at > 0 && hit_distances[at - 1] > d2) {
                        hits[at] = hits[at - 1];
                        hit_distances[at] = hit_distances[at - 1];
                        --at;
                    }
                    hits[at] = int(j);
                    hit_distances[at] = d2;
                    n = std::min(n + 1, k);
                }
            }
        }
    }, tbb::simple_partitioner{});
}

}  // namespace

std::vector<Correspondence> match_descriptors(const Features& model, const Features& scene, const MatchParams& params)
{
    if (!(params.threshold > 0.0f)) throw Error("match_descriptors", "match_threshold must be positive");
    if (params.k < 1) throw Error("match_descriptors", "match k must be at least 1");
    if (params.search == MatchSearch::randomized && (params.trees < 1 || params.checks < 1))
        throw Error("match_descriptors", "approximate matching needs trees >= 1 and checks >= 1");
    if (model.size() == 0 || scene.size() == 0) return {};

    const bool model_to_scene = params.direction == MatchDirection::model_to_scene;
    const Features& indexed = model_to_scene ? scene : model;
    const Features& queried = model_to_scene ? model : scene;
    const int k = model_to_scene ? std::min<int>(params.k, int(indexed.size())) : 1;

    std::vector<int> found(queried.size() * std::size_t(k), -1);
    std::vector<float> distances(queried.size() * std::size_t(k), 0.0f);
    if (params.search == MatchSearch::scan) {
        scan_nearest(indexed, queried, k, params.threshold, found, distances);
    } else {
        const flann::Matrix<float> data(const_cast<float*>(indexed.descriptors.data()), indexed.size(), shot_size);
        std::unique_ptr<flann::Index<ShotDistance>> index;
        if (params.search == MatchSearch::kdtree) {
            index = std::make_unique<flann::Index<ShotDistance>>(data, flann::KDTreeSingleIndexParams(15));
        } else {
            // Seeding fixes FLANN's split choices; its input shuffle uses std::random_device, so
            // approximate matches can still differ from run to run (the README says so).
            flann::seed_random(1);
            index = std::make_unique<flann::Index<ShotDistance>>(data, flann::KDTreeIndexParams(params.trees));
        }
        index->buildIndex();
        const flann::SearchParams search(params.search == MatchSearch::kdtree ? flann::FLANN_CHECKS_UNLIMITED
                                                                               : params.checks);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queried.size(), 64), [&](const auto& range) {
            const std::size_t count = range.end() - range.begin();
            flann::Matrix<float> queries(const_cast<float*>(queried.descriptors.data()) + range.begin() * shot_size,
                                         count, shot_size);
            flann::Matrix<int> indices(found.data() + range.begin() * std::size_t(k), count, std::size_t(k));
            flann::Matrix<float> dists(distances.data() + range.begin() * std::size_t(k), count, std::size_t(k));
            flann::SearchParams local = search;
            local.cores = 1;
            index->knnSearch(queries, indices, dists, std::size_t(k), local);
        });
    }

    std::vector<Correspondence> out;
    for (std::size_t q = 0; q < queried.size(); ++q) {
        for (int j = 0; j < k; ++j) {
            const int hit = found[q * std::size_t(k) + std::size_t(j)];
            const float d2 = distances[q * std::size_t(k) + std::size_t(j)];
            if (hit < 0 || !(d2 < params.threshold)) continue;
            out.push_back(model_to_scene ? Correspondence{std::uint32_t(q), std::uint32_t(hit), d2}
                                         : Correspondence{std::uint32_t(hit), std::uint32_t(q), d2});
        }
    }
    std::sort(out.begin(), out.end(), [](const Correspondence& a, const Correspondence& b) {
        return a.model != b.model ? a.model < b.model : a.scene < b.scene;
    });
    return out;
}

}  // namespace mfpc
