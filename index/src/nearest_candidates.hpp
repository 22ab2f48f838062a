#pragma once

// Private to index/: what the grid and the organized searches share, so that they give the same
// answers: the squared distance, the k-best list and the query check.

#include <algorithm>
#include <bit>
#include <cassert>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "mfpc/core/error.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc::detail {

// The squared distance of a point from a query, in float and in this order (what FLANN, PCL's
// kd-tree, computes): every search computes it so, and so agrees on ties and radius tests.
inline float squared_distance(const Point& point, const Point& query)
{
    const float dx = point.x() - query.x();
    const float dy = point.y() - query.y();
    const float dz = point.z() - query.z();
    return dx * dx + dy * dy + dz * dz;
}

// (squared distance, point index): ordered so that ties go to the lower index.
using Candidate = std::pair<float, std::uint32_t>;

// A candidate packed in one integer that orders as the pair: squared distances are >= +0 (never
// NaN: points and queries are finite), where floats order as their bits.
inline std::uint64_t candidate_key(float squared_distance, std::uint32_t index)
{
    return std::uint64_t(std::bit_cast<std::uint32_t>(squared_distance)) << 32 | index;
}

inline Candidate candidate_of(std::uint64_t key)
{
    return {std::bit_cast<float>(std::uint32_t(key >> 32)), std::uint32_t(key)};
}

// Moves the n smallest of `keys` (0 < n <= size), ascending, to its front: an insertion sort of the
// first n, then each later key against the n-th, which most fail. On packed keys, in place, this
// beats keep_nearest (its pair compares and vector pushes were a third of the organized search).
// Forced inline: GCC 12 kept it out of line, at 4% of that search.
__attribute__((always_inline)) inline void select_smallest(std::span<std::uint64_t> keys, std::size_t n)
{
    assert(n > 0 && n <= keys.size());
    for (std::size_t j = 1; j < n; ++j) {
        const std::uint64_t key = keys[j];
        std::size_t p = j;
        for (; p > 0 && key < keys[p - 1]; --p) keys[p] = keys[p - 1];
        keys[p] = key;
    }
    for (std::size_t j = n; j < keys.size(); ++j) {
        const std::uint64_t key = keys[j];
        if (key >= keys[n - 1]) continue;
        std::size_t p = n - 1;
        for (; p > 0 && key < keys[p - 1]; --p) keys[p] = keys[p - 1];
        keys[p] = key;
    }
}

// Keeps `best` the sorted `want` smallest candidates seen. For the small k of normal estimation an
// insertion from the back beats a heap (and vector::insert, whose memmove call cost more than the
// few moves it makes), and most candidates fail the first compare.
// want must be positive: callers return before searching when no neighbour is wanted.
inline void keep_nearest(std::vector<Candidate>& best, std::size_t want, const Candidate& candidate)
{
    assert(want > 0);
    if (best.size() == want) {
        // Most candidates are farther than the k-th best: one float compare, not the pair's.
        if (candidate.first > best.back().first || !(candidate < best.back())) return;
    } else {
        best.push_back(candidate);
    }
    std::size_t i = best.size() - 1;
    for (; i > 0 && candidate < best[i - 1]; --i) best[i] = best[i - 1];
    best[i] = candidate;
}

// The k-nearest searches' check: a query that is not finite has no nearest points (its distances
// are all NaN or infinite), and its cell does not fit an int. Throws mfpc::Error naming the first.
inline void check_finite_queries(std::span<const Point> queries)
{
    for (std::size_t q = 0; q < queries.size(); ++q)
        if (!queries[q].allFinite())
            throw Error("neighbour grid", "k-nearest query " + std::to_string(q) + " is not finite");
}

}  // namespace mfpc::detail
