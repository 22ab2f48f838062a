#include "mfpc/index/distinct_points.hpp"

#include <algorithm>
#include <bit>
#include <numeric>
#include <tuple>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "radix_sort.hpp"

namespace mfpc {

namespace {

// The bits of a coordinate with -0 read as +0: equal floats, equal bits.
std::uint32_t coordinate_bits(float value) { return value == 0.0f ? 0u : std::bit_cast<std::uint32_t>(value); }

// 32 bits of a strong mix of the three coordinates (the finaliser of a 64-bit hash), so that
// runs of equal hashes are exact duplicates but for rare collisions.
std::uint32_t position_hash(const Point& p)
{
    std::uint64_t h = (std::uint64_t(coordinate_bits(p.x())) << 32 | coordinate_bits(p.y())) * 0x9e3779b97f4a7c15ull;
    h ^= coordinate_bits(p.z()) * 0xc2b2ae3d27d4eb4full;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return std::uint32_t(h);
}

bool same_position(const Point& a, const Point& b)
{
    return a.x() == b.x() && a.y() == b.y() && a.z() == b.z();
}

}  // namespace

std::vector<std::uint32_t> DistinctPoints::representatives(std::size_t n) const
{
    std::vector<std::uint32_t> out;
    out.reserve(first.empty() ? n : count);
    for (std::size_t i = 0; i < n; ++i)
        if (first.empty() || first[i] == i) out.push_back(std::uint32_t(i));
    return out;
}

DistinctPoints distinct_points(std::span<const Point> points)
{
    const std::size_t n = points.size();
    if (n >= (std::size_t(1) << 32)) throw Error("distinct points", "clouds of 2^32 points or more are not supported");
    DistinctPoints result;
    result.count = n;
    if (n < 2) return result;

    // Hash in the high word, index in the low: a stable sort by the high word keeps each run of
    // equal hashes in index order, so the first of a run is its first occurrence.
    std::vector<std::uint64_t> entries(n);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 16384), [&](const tbb::blocked_range<std::size_t>& r) {
        for (std::size_t i = r.begin(); i < r.end(); ++i)
            entries[i] = std::uint64_t(position_hash(points[i])) << 32 | std::uint64_t(i);
    });
    detail::radix_sort(entries, 32, 32, [](std::uint64_t e) { return e; });

    // Within a run of equal hashes, order by the coordinates' bits (then index): equal positions
    // become neighbours, the first of each the earliest point, and a run of colliding positions
    // costs a sort rather than a comparison of every pair.
    const auto position_key = [&](std::uint64_t entry) {
        const Point& p = points[std::uint32_t(entry)];
        return std::tuple(coordinate_bits(p.x()), coordinate_bits(p.y()), coordinate_bits(p.z()), std::uint32_t(entry));
    };
    for (std::size_t start = 0; start < n;) {
        std::size_t end = start + 1;
        while (end < n && (entries[end] >> 32) == (entries[start] >> 32)) ++end;
        if (end - start > 1) {
            const auto by_position = [&](std::uint64_t a, std::uint64_t b) { return position_key(a) < position_key(b); };
            const auto run_begin = entries.begin() + std::ptrdiff_t(start), run_end = entries.begin() + std::ptrdiff_t(end);
            if (!std::is_sorted(run_begin, run_end, by_position)) std::sort(run_begin, run_end, by_position);
            std::uint32_t head = std::uint32_t(entries[start]);
            for (std::size_t e = start + 1; e < end; ++e) {
                const auto index = std::uint32_t(entries[e]);
                if (!same_position(points[index], points[head])) {
                    head = index;
                    continue;
                }
                if (result.first.empty()) {
                    result.first.resize(n);
                    std::iota(result.first.begin(), result.first.end(), 0u);
                }
                result.first[index] = head;
                --result.count;
            }
        }
        start = end;
    }
    return result;
}

}  // namespace mfpc
