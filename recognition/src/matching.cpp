#include "mfpc/recognition/matching.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <type_traits>
#include <memory>
#include <numeric>
#include <span>
#include <string>

#include <flann/flann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "mfpc/kernels/detail/lanes.hpp"
#include "mfpc/kernels/shot.hpp"

namespace mfpc {
namespace {

// 8 lanes (mfpc/kernels/detail/lanes.hpp): with AVX2 a single register, otherwise two SSE halves.
// Passed by reference and loaded in place, never by value: that would change the ABI where the
// function is not compiled for AVX.
using detail::Float8;
using detail::Int8;

float lane_total(const Float8& sum)
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
    Float8 sum = {0, 0, 0, 0, 0, 0, 0, 0};
    std::size_t i = 0;
    for (; i + 32 <= size; i += 32) {
        for (std::size_t j = i; j < i + 32; j += 8) {
            Float8 a, b;
            detail::load(a, x + j);
            detail::load(b, y + j);
            const Float8 d = a - b;
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

// Each descriptor cut into 44 groups of 8 consecutive values, and the Euclidean norm of each
// group. By Cauchy-Schwarz on every group, the dot product of two descriptors' group norms bounds
// the dot product of the descriptors from above. 44 groups of 8 measured the best trade between
// the cost of the bounds and how many pairs they leave (7% on milk_pair, against 16% with 32
// groups of 11 and 5% with 88 of 4).
constexpr std::size_t group_size = 8;
constexpr std::size_t group_count = shot_size / group_size;
static_assert(shot_size % group_size == 0);

// Descriptors side by side, 16 at a time: the group norms of descriptors 16 i to 16 i + 15 are
// one tile of group_count x 16 (group-major), so a block of 16 columns is read in one sweep.
constexpr std::size_t tile_size = group_count * 16;

// Descriptor counts rounded up to whole tiles.
inline std::size_t whole_tiles(std::size_t count) { return (count + 15) / 16 * 16; }

// The group norms of every descriptor: rows of group_count when `tiled` is false, else tiles of
// 16 descriptors (zeros beyond the last one).
std::vector<float> group_norms(const Features& f, bool tiled)
{
    std::vector<float> norms((tiled ? whole_tiles(f.size()) : f.size()) * group_count, 0.0f);
    // In parallel: a scene's descriptors are megabytes, and a serial pass over them was a sixth
    // of the scan's time at 1 thread.
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, f.size(), 256), [&](const auto& range) {
        for (std::size_t i = range.begin(); i < range.end(); ++i) {
            const auto v = f.descriptor(i);
            for (std::size_t g = 0; g < group_count; ++g) {
                float sum = 0.0f;
                for (std::size_t j = g * group_size; j < (g + 1) * group_size; ++j) sum += v[j] * v[j];
                norms[tiled ? i / 16 * tile_size + g * 16 + i % 16 : i * group_count + g] = std::sqrt(sum);
            }
        }
    });
    return norms;
}

// For query r < query_count and data column c < width (a multiple of 16): a lower bound of their
// squared distance, |q|^2 + |d|^2 - 2 x (the dot product of their group norms), less the
// acceptance bound `threshold` and a margin of 1e-3 (|q|^2 + |d|^2), into slack[r * width + c]. The
// bound's rounding (norms of 352 terms, square roots, products and sums, in float) stays below
// about 3e-5 (|q|^2 + |d|^2), the margin is 30 times that: a pair whose distance is below some
// worst <= threshold has slack below worst - threshold. NaN descriptors give NaN, below nothing.
// Query rows of group_count norms; data columns in tiles of 16 (group_norms), with their squared
// norms padded alike. Columns side by side in the vector lanes and four queries at a time: eight sums
// in registers, and no sum across lanes. Only a filter (the distances that decide are
// descriptor_distance's), so its rounding, FMA or not, may differ from machine to machine.
[[gnu::always_inline]] inline void slack_block(const float* queries, const float* query_norms, std::size_t query_count,
                                               const float* columns, const float* column_norms, std::size_t width,
                                               float threshold, float* slack, std::uint16_t* masks)
{
    constexpr std::size_t rows = 4;
    constexpr Int8 low_weights = {1, 2, 4, 8, 16, 32, 64, 128};
    constexpr Int8 high_weights = low_weights << 8;
    constexpr float keep = 1.0f - 1e-3f;
    for (std::size_t r0 = 0; r0 < query_count; r0 += rows) {
        std::size_t row[rows];
        for (std::size_t r = 0; r < rows; ++r) row[r] = std::min(r0 + r, query_count - 1);
        for (std::size_t c = 0; c < width; c += 16) {
            Float8 sum[rows][2] = {};
            const float* tile = columns + c / 16 * tile_size;
            for (std::size_t g = 0; g < group_count; ++g) {
                Float8 low, high;
                detail::load(low, tile + g * 16);
                detail::load(high, tile + g * 16 + 8);
#pragma GCC unroll 4
                for (std::size_t r = 0; r < rows; ++r) {
                    const float norm = queries[row[r] * group_count + g];
                    sum[r][0] += norm * low;
                    sum[r][1] += norm * high;
                }
            }
            Float8 norms_low, norms_high;
            detail::load(norms_low, column_norms + c);
            detail::load(norms_high, column_norms + c + 8);
            for (std::size_t r = 0; r < rows && r0 + r < query_count; ++r) {
                const float query_norm = query_norms[row[r]];
                const Float8 low_slack = keep * (query_norm + norms_low) - 2.0f * sum[r][0] - threshold;
                const Float8 high_slack = keep * (query_norm + norms_high) - 2.0f * sum[r][1] - threshold;
                detail::store(slack + (r0 + r) * width + c, low_slack);
                detail::store(slack + (r0 + r) * width + c + 8, high_slack);
                // Bit l of the mask: column c + l has negative slack (a comparison gives -1 where
                // it holds; NaN compares false).
                const Int8 bits = ((low_slack < 0.0f) & low_weights) | ((high_slack < 0.0f) & high_weights);
                masks[(r0 + r) * (width / 16) + c / 16] =
                    std::uint16_t((bits[0] | bits[1]) | (bits[2] | bits[3]) | ((bits[4] | bits[5]) | (bits[6] | bits[7])));
            }
        }
    }
}

// Chosen at load time: 8-lane FMA where the machine has it, SSE's 4 lanes twice otherwise.
#if defined(__x86_64__) && defined(__GNUC__)
__attribute__((target("avx2,fma"))) void slack_products(const float* queries, const float* query_norms,
                                                       std::size_t query_count, const float* columns,
                                                       const float* column_norms, std::size_t width, float threshold,
                                                       float* slack, std::uint16_t* masks)
{
    slack_block(queries, query_norms, query_count, columns, column_norms, width, threshold, slack, masks);
}
__attribute__((target("default")))
#endif
void slack_products(const float* queries, const float* query_norms, std::size_t query_count, const float* columns,
                    const float* column_norms, std::size_t width, float threshold, float* slack, std::uint16_t* masks)
{
    slack_block(queries, query_norms, query_count, columns, column_norms, width, threshold, slack, masks);
}

// The up to k nearest data descriptors of each query with squared distance below threshold, by
// (distance, index), written as found/distances rows of k (-1 where fewer). An exhaustive scan:
// in 352 dimensions a kd-tree visits nearly every leaf anyway, and a scan can take its bounds in
// bulk. Since |q - d|^2 = |q|^2 + |d|^2 - 2 q.d and q.d is at most the dot product of the group
// norms, blocked products of those (7 times shorter than the descriptors) rule out all but the
// pairs that may come under the acceptance bound; those get the exact distance.
void scan_nearest(const Features& data, const Features& queries, int k, float threshold, std::span<int> found,
                  std::span<float> distances)
{
    // Padded with zeros to `size`.
    const auto squared_norms = [](const Features& f, std::size_t size) {
        std::vector<float> norms(size, 0.0f);
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, f.size(), 256), [&](const auto& range) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) {
                const auto v = f.descriptor(i);
                norms[i] = std::inner_product(v.begin(), v.end(), v.begin(), 0.0f);
            }
        });
        return norms;
    };
    const std::vector<float> query_groups = group_norms(queries, false);
    const std::vector<float> data_groups = group_norms(data, true);
    const std::vector<float> query_norms = squared_norms(queries, queries.size());
    const std::vector<float> data_norms = squared_norms(data, whole_tiles(data.size()));
    // Query rows per task and data columns per block (a multiple of 16; 128, 256 and 512 measured
    // alike, within the noise). The simple partitioner keeps tasks at task_rows whatever the thread
    // count.
    constexpr std::size_t task_rows = 48, block_columns = 128;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), task_rows), [&](const auto& range) {
        const std::size_t count = range.end() - range.begin();
        std::vector<float> slack(count * block_columns);
        std::vector<std::uint16_t> masks(count * block_columns / 16);
        std::vector<int> kept(count, 0);  // how many results each query has so far in found/distances
        for (std::size_t b0 = 0; b0 < data.size(); b0 += block_columns) {
            const std::size_t block = std::min(block_columns, data.size() - b0);
            const std::size_t width = whole_tiles(block);
            slack_products(query_groups.data() + range.begin() * group_count, query_norms.data() + range.begin(),
                           count, data_groups.data() + b0 / 16 * tile_size, data_norms.data() + b0, width, threshold,
                           slack.data(), masks.data());
            for (std::size_t r = 0; r < count; ++r) {
                const std::size_t q = range.begin() + r;
                const float* query = queries.descriptors.data() + q * shot_size;
                int* hits = found.data() + q * std::size_t(k);
                float* hit_distances = distances.data() + q * std::size_t(k);
                int& n = kept[r];
                // The columns that may come under the acceptance bound (about 7%), by their mask
                // bits, then held against the current worst. Padding columns (c >= block) are
                // never read.
                const float* own = slack.data() + r * width;
                const std::uint16_t* own_masks = masks.data() + r * (width / 16);
                for (std::size_t c0 = 0; c0 < block; c0 += 16) {
                    for (unsigned bits = own_masks[c0 / 16]; bits != 0; bits &= bits - 1) {
                        const std::size_t c = c0 + std::size_t(std::countr_zero(bits));
                        if (c >= block) break;
                        const float worst = n < k ? threshold : hit_distances[k - 1];
                        if (!(own[c] < worst - threshold)) continue;
                        const std::size_t j = b0 + c;
                        const float d2 =
                            descriptor_distance(query, data.descriptors.data() + j * shot_size, shot_size, worst);
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
